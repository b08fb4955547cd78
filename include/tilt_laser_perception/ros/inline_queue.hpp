// Callbacks without a thread hand-over, for the head's high-rate in-process
// topics (issue 18: each 200 Hz joint state cost a wake-up of the nodelet
// manager's dispatch thread and of a worker, per subscriber).
//
// InlineCallbackQueue runs a callback at once, in the thread that delivers
// it: for a message published in the same process, the publisher's own
// thread; for one from another process (a bag, a robot's joint states), the
// thread roscpp reads it on. Give it only to callbacks that are short and
// thread-safe (they may run in several threads at once and must not block on
// a lock held for long): here, a callback that puts the message in an inbox,
// and the tf listener's insert into its buffer. roscpp holds one lock of its
// own over every publish in the process, and an in-process message's
// callbacks run inside that publish: an inline callback must not wait for a
// lock that another thread holds while it publishes. Nor may it publish when
// it runs for a message of another process: roscpp's receiving thread then
// holds the subscription's lock, which an in-process publisher of the same
// topic waits for while it holds the publish lock (the head stopped dead so:
// HeadStatePublisher hands such messages to its nodelet's queue).
//
// TaskCallback is one job for an ordinary callback queue (the nodelet's own:
// run by its worker like any of its callbacks).
#pragma once

#include <cstdint>
#include <functional>
#include <thread>
#include <utility>

#include <ros/callback_queue_interface.h>

namespace tilt_laser_perception {

class InlineCallbackQueue : public ros::CallbackQueueInterface {
 public:
  /// after: run after each callback (e.g. to wake a worker that waits for this input).
  explicit InlineCallbackQueue(std::function<void()> after = {}) : after_(std::move(after)) {}
  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t /*owner_id*/ = 0) override {
    if (!callback->ready()) return;
    // TryAgain: a subscription that forbids concurrent callbacks is in its
    // callback in another thread right now; it is short, so wait it out.
    while (callback->call() == ros::CallbackInterface::TryAgain) std::this_thread::yield();
    if (after_) after_();
  }
  void removeByID(uint64_t /*owner_id*/) override {}  // nothing is ever held

 private:
  std::function<void()> after_;
};

class TaskCallback : public ros::CallbackInterface {
 public:
  explicit TaskCallback(std::function<void()> f) : f_(std::move(f)) {}
  CallResult call() override {
    f_();
    return Success;
  }

 private:
  std::function<void()> f_;
};

}  // namespace tilt_laser_perception
