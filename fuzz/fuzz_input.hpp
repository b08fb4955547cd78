// A small reader of fuzzer input: takes numbers off the front of the bytes,
// zeros once they run out.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace tlp_fuzz {
class Input {
 public:
  Input(const std::uint8_t* data, std::size_t size) : p_(data), n_(size) {}
  template <typename T>
  T take() {
    T v{};
    const std::size_t k = n_ < sizeof(T) ? n_ : sizeof(T);
    std::memcpy(&v, p_, k);
    p_ += k;
    n_ -= k;
    return v;
  }
  /// An integer in [0, bound).
  unsigned below(unsigned bound) { return bound ? take<std::uint16_t>() % bound : 0; }
  std::size_t left() const { return n_; }
  const std::uint8_t* rest() const { return p_; }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
};
}  // namespace tlp_fuzz

// Invariant checks: a broken one aborts, and libFuzzer keeps the input.
#define TLP_FUZZ_CHECK(cond) \
  do {                       \
    if (!(cond)) __builtin_trap(); \
  } while (0)
