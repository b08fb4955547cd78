// The robot head without the robot: an emulated UTM-30LX-EW (SCIP 2.0 on a
// loopback TCP port) and an emulated MX-64 (Dynamixel 1.0/2.0 on a pseudo
// terminal) on one clock and one motion, scanning a simulated scene.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tilt_laser_perception/sim/mx64_emulator.hpp"
#include "tilt_laser_perception/sim/utm_emulator.hpp"

using namespace tilt_laser_perception;

namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }

void usage() {
  std::fprintf(stderr,
      "usage: tilt_laser_sim --scene NAME [--protocol 1|2] [--seed N] [--port P] [--truth FILE]\n"
      "                      [--fault SPEC]... [--servo-link PATH] [--id N] [--drift PPM]\n"
      "                      [--clock-offset MS] [--motor-ppm PPM] [--noise datasheet|percent|none]\n"
      "                      [--initial-tilt DEG] [--laser-boot-time S] [--no-multi-echo] [--servo-limits-deg LO,HI]\n"
      "                      [--head FILE] [--duration S] [--walk SPEED ... --walk-clock FILE]\n"
      "Prints the laser's address (host:port) and the servo's device path, one per line.\n"
      "  --laser-boot-time S: the laser is unreachable this long after a reboot (default 10, its data sheet's)\n"
      "  --no-multi-echo: a UTM-30LX without -EW (ND/NE/HD/HE answered 0E)\n"
      "  --servo-limits-deg LO,HI: the servo's position limits set so (default: the e-manual's, the whole turn)\n"
      "Fault SPEC is NAME@T[:ARG], T seconds after start:\n"
      "  laser: drop@T  silent@T[:DURATION]  corrupt@T[:SCANS]  truncate@T[:SCANS]  delay@T:MS (0 ends it)  reboot@T\n"
      "  servo: servo-noreply@T[:DURATION]  servo-badcrc@T[:N]  servo-garbage@T[:N]\n"
      "         servo-overload@T  servo-overheat@T  servo-voltage@T  servo-clear@T  servo-vanish@T[:DURATION]\n"
      "  --walk-clock FILE: where the walk's start (host time) is written, for sim_odometry\n"
      "%s%s", sim::rigOptionsUsage(), sim::walkOptionsUsage());
}

struct Fault {
  std::string name;
  double at = 0.0;
  double arg = -1.0;
};

bool parseFault(const std::string& spec, Fault& f) {
  const std::size_t at = spec.find('@');
  if (at == std::string::npos) return false;
  f.name = spec.substr(0, at);
  const std::string rest = spec.substr(at + 1);
  const std::size_t colon = rest.find(':');
  char* end = nullptr;
  f.at = std::strtod(rest.substr(0, colon).c_str(), &end);
  if (colon != std::string::npos) f.arg = std::atof(rest.substr(colon + 1).c_str());
  static const char* known[] = {"drop", "silent", "corrupt", "truncate", "delay", "reboot", "servo-noreply",
                                "servo-badcrc", "servo-garbage", "servo-overload", "servo-overheat",
                                "servo-voltage", "servo-clear", "servo-vanish"};
  for (const char* k : known)
    if (f.name == k) return true;
  return false;
}
}  // namespace

int main(int argc, char** argv) {
  std::string scene_name, truth_path, link, head_path;
  int protocol = 2, id = 1;
  unsigned long seed = 1;
  double initial_tilt_deg = 30.0, duration = 0.0;
  double servo_limits[2] = {0.0, 0.0};  // [deg]; equal: the e-manual's initial values
  sim::UtmOptions utm_opt;
  sim::NoiseParams noise;
  sim::RigErrors rig;
  std::vector<Fault> faults;
  sim::WalkParams walk_params;
  std::string walk_clock;
  // roslaunch appends __name:= and __log:= arguments: leave them out.
  std::vector<char*> args{argv[0]};
  for (int i = 1; i < argc; ++i)
    if (std::strstr(argv[i], ":=") == nullptr) args.push_back(argv[i]);
  argc = static_cast<int>(args.size());
  argv = args.data();
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool v = i + 1 < argc;
    if (a == "--truth" && (!v || std::strncmp(argv[i + 1], "--", 2) == 0)) continue;  // an empty --truth: none
    try {
      if (sim::parseRigOption(argc, argv, i, rig, noise) || sim::parseWalkOption(argc, argv, i, walk_params)) continue;
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "tilt_laser_sim: %s\n", e.what());
      return 2;
    }
    if (a == "--scene" && v) scene_name = argv[++i];
    else if (a == "--protocol" && v) protocol = std::atoi(argv[++i]);
    else if (a == "--seed" && v) seed = std::strtoul(argv[++i], nullptr, 10);
    else if (a == "--port" && v) utm_opt.port = static_cast<std::uint16_t>(std::atoi(argv[++i]));
    else if (a == "--truth" && v) truth_path = argv[++i];
    else if (a == "--servo-link" && v) link = argv[++i];
    else if (a == "--walk-clock" && v) walk_clock = argv[++i];
    else if (a == "--id" && v) id = std::atoi(argv[++i]);
    else if (a == "--drift" && v) utm_opt.drift_ppm = std::atof(argv[++i]);
    else if (a == "--clock-offset" && v) utm_opt.clock_offset_ms = std::atof(argv[++i]);
    else if (a == "--motor-ppm" && v) utm_opt.motor_ppm = std::atof(argv[++i]);
    else if (a == "--initial-tilt" && v) initial_tilt_deg = std::atof(argv[++i]);
    else if (a == "--laser-boot-time" && v) utm_opt.reboot_time = std::max(0.0, std::atof(argv[++i]));
    else if (a == "--no-multi-echo") utm_opt.multi_echo = false;
    else if (a == "--servo-limits-deg" && v) {
      if (std::sscanf(argv[++i], "%lf,%lf", &servo_limits[0], &servo_limits[1]) != 2 ||
          !(servo_limits[0] < servo_limits[1])) {
        std::fprintf(stderr, "tilt_laser_sim: --servo-limits-deg LO,HI with LO < HI\n");
        return 2;
      }
    }
    else if (a == "--head" && v) head_path = argv[++i];
    else if (a == "--duration" && v) duration = std::atof(argv[++i]);
    else if (a == "--noise" && v) {
      if (!sim::parseNoiseMode(argv[++i], noise.mode)) { usage(); return 2; }
    } else if (a == "--fault" && v) {
      Fault f;
      if (!parseFault(argv[++i], f)) {
        std::fprintf(stderr, "tilt_laser_sim: bad fault '%s'\n", argv[i]);
        usage();
        return 2;
      }
      faults.push_back(f);
    } else if (a == "-h" || a == "--help") { usage(); return 0; }
    else { usage(); return 2; }
  }
  if (scene_name.empty() || (protocol != 1 && protocol != 2) || id < 0 || id > 252) { usage(); return 2; }

  try {
    const sim::Scene scene = sim::loadScene(scene_name);
    const sim::HeadGeometry head =
        head_path.empty() ? sim::HeadGeometry::load(sim::configDirectory() + "/head.yaml") : sim::HeadGeometry::load(head_path);
    const double start = sim::hostNow();
    sim::ServoModel servo(initial_tilt_deg * M_PI / 180.0, start);
    sim::HeadSimulator head_sim(scene, head, servo, noise, seed, sim::LidarModel(), rig);
    // A walking robot: the walk begins now; its clock goes to --walk-clock for
    // sim_odometry, which publishes the odometry's odom -> base_footprint.
    walk_params.start_time = start;
    const sim::WalkModel walk(scene, walk_params);
    if (walk_params.walking()) head_sim.setWalk(&walk);
    if (!walk_clock.empty()) {
      const std::string tmp = walk_clock + ".tmp";
      std::FILE* f = std::fopen(tmp.c_str(), "w");
      if (!f) throw std::runtime_error("cannot write " + tmp);
      std::fprintf(f, "%.6f\n", start);
      std::fclose(f);
      std::rename(tmp.c_str(), walk_clock.c_str());  // whole, or not at all
    }

    std::ofstream truth;
    if (!truth_path.empty()) {
      truth.open(truth_path);
      if (!truth) throw std::runtime_error("cannot write " + truth_path);
      truth << "# tilt_laser_sim ground truth, scene " << scene.name << "\n"
            << "# per scan: start_time [s, host], tilt of every beam [rad] (1081 values), '|', then the face\n"
            << "# hit by every beam as runs 'face*count' (-1: none), '|', then the noise-free range of every\n"
            << "# beam [mm] (-1: nothing hit)\n";
    }
    std::mutex sim_mutex;
    sim::HeadScan hs;
    const sim::ScanSource source = [&](double t0, sim::SimScan& out) {
      std::lock_guard<std::mutex> l(sim_mutex);
      head_sim.scan(t0, hs);
      out = hs.scan;
      if (truth.is_open()) {
        char buf[32];
        std::snprintf(buf, sizeof(buf), "%.6f", t0);
        truth << buf;
        for (float tl : hs.tilt) {
          std::snprintf(buf, sizeof(buf), " %.5f", tl);
          truth << buf;
        }
        truth << " |";
        const auto& f = hs.scan.face;
        for (std::size_t i = 0; i < f.size();) {
          std::size_t j = i;
          while (j < f.size() && f[j] == f[i]) ++j;
          truth << ' ' << f[i] << '*' << (j - i);
          i = j;
        }
        truth << " |";
        for (float r : hs.scan.true_ranges) truth << ' ' << (std::isfinite(r) ? static_cast<long>(std::lround(r * 1000.0)) : -1L);
        truth << '\n';
      }
    };

    sim::UtmEmulator laser(source, utm_opt);
    laser.start();
    sim::Mx64Options mx;
    mx.protocol = protocol == 1 ? dynamixel::Protocol::V1 : dynamixel::Protocol::V2;
    mx.id = static_cast<std::uint8_t>(id);
    mx.link_path = link;
    if (servo_limits[0] < servo_limits[1]) {
      mx.limit_lo = dynamixel::radToPosition(servo_limits[0] * M_PI / 180.0);
      mx.limit_hi = dynamixel::radToPosition(servo_limits[1] * M_PI / 180.0);
    }
    sim::Mx64Emulator servo_emu(servo, mx);
    servo_emu.start();

    std::printf("%s\n%s\n", laser.address().c_str(), servo_emu.devicePath().c_str());
    std::fflush(stdout);
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);

    // Faults, in time order, each undone after its duration where it has one.
    struct Timed { double at; std::function<void()> act; };
    std::vector<Timed> plan;
    for (const Fault& f : faults) {
      const double t = start + f.at;
      const double arg = f.arg;
      if (f.name == "drop") plan.push_back({t, [&] { laser.dropConnection(); }});
      else if (f.name == "silent") {
        plan.push_back({t, [&] { laser.setSilent(true); }});
        if (arg > 0) plan.push_back({t + arg, [&] { laser.setSilent(false); }});
      } else if (f.name == "corrupt") plan.push_back({t, [&, arg] { laser.corruptNextScans(arg > 0 ? int(arg) : 1); }});
      else if (f.name == "truncate") plan.push_back({t, [&, arg] { laser.truncateNextScans(arg > 0 ? int(arg) : 1); }});
      else if (f.name == "delay") plan.push_back({t, [&, arg] { laser.setReplyDelay(arg >= 0 ? arg / 1000.0 : 0.1); }});  // delay@T:0 ends it
      else if (f.name == "reboot") plan.push_back({t, [&] { laser.reboot(); }});
      else if (f.name == "servo-noreply") {
        plan.push_back({t, [&] { servo_emu.setNoReply(true); }});
        if (arg > 0) plan.push_back({t + arg, [&] { servo_emu.setNoReply(false); }});
      } else if (f.name == "servo-badcrc") plan.push_back({t, [&, arg] { servo_emu.corruptNextReplies(arg > 0 ? int(arg) : 1); }});
      else if (f.name == "servo-garbage") plan.push_back({t, [&, arg] { servo_emu.garbageBeforeNextReplies(arg > 0 ? int(arg) : 1); }});
      else if (f.name == "servo-overload") plan.push_back({t, [&] { servo_emu.setHardwareError(0x20); }});
      else if (f.name == "servo-overheat") plan.push_back({t, [&] { servo_emu.setHardwareError(0x04); }});
      else if (f.name == "servo-voltage") plan.push_back({t, [&] { servo_emu.setHardwareError(0x01); }});
      else if (f.name == "servo-clear") plan.push_back({t, [&] { servo_emu.setHardwareError(0); }});
      else if (f.name == "servo-vanish") {
        plan.push_back({t, [&] { servo_emu.vanish(); }});
        if (arg > 0) plan.push_back({t + arg, [&] { servo_emu.reappear(); }});
      }
    }
    std::sort(plan.begin(), plan.end(), [](const Timed& a, const Timed& b) { return a.at < b.at; });
    std::size_t next = 0;
    while (!g_stop && (duration <= 0.0 || sim::hostNow() < start + duration)) {
      while (next < plan.size() && plan[next].at <= sim::hostNow()) plan[next++].act();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    servo_emu.stop();
    laser.stop();
    std::fprintf(stderr, "tilt_laser_sim: %lu scans sent, %lu servo packets\n", laser.stats().scans_sent.load(),
                 servo_emu.stats().packets.load());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tilt_laser_sim: %s\n", e.what());
    return 1;
  }
  return 0;
}
