#include "rtukit/driver/bus_worker.hpp"

#include <algorithm>
#include <utility>

namespace rtukit {

BusWorker::BusWorker(Step step, Options options)
    : step_(std::move(step)), options_(options), clock_(clock_or_steady(options.clock)) {}

BusWorker::~BusWorker() {
  stop();
}

void BusWorker::start() {
  std::lock_guard life(lifecycle_);
  if (thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stopping_ = false;
    running_ = true;
  }
  thread_ = std::thread([this] { run(); });
}

bool BusWorker::post(std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || jobs_.size() >= options_.job_limit) return false;
    jobs_.push_back(std::move(job));
  }
  cv_.notify_one();
  return true;
}

void BusWorker::wake() {
  {
    std::lock_guard lock(mutex_);
    woken_ = true;
  }
  cv_.notify_one();
}

void BusWorker::stop() {
  std::lock_guard life(lifecycle_);
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
    jobs_.clear();
  }
  cv_.notify_one();
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  running_ = false;
}

size_t BusWorker::pending() const {
  std::lock_guard lock(mutex_);
  return jobs_.size();
}

bool BusWorker::running() const {
  std::lock_guard lock(mutex_);
  return running_ && !stopping_;
}

bool BusWorker::stopped() const {
  std::lock_guard lock(mutex_);
  return stopping_;
}

std::deque<std::function<void()>> BusWorker::take_jobs() {
  std::lock_guard lock(mutex_);
  woken_ = false;
  return std::exchange(jobs_, {});
}

BusWorker::TimePoint BusWorker::run_once() {
  for (auto& job : take_jobs()) job();
  return step_(clock_.now());
}

void BusWorker::run() {
  for (;;) {
    // Jobs one at a time, so stop() is seen between two of them.
    for (;;) {
      std::function<void()> job;
      {
        std::lock_guard lock(mutex_);
        if (stopping_) return;
        woken_ = false;
        if (jobs_.empty()) break;
        job = std::move(jobs_.front());
        jobs_.pop_front();
      }
      job();
    }
    const TimePoint next = step_(clock_.now());
    std::unique_lock lock(mutex_);
    // A wait of the clock's duration, bounded: the clock may be a virtual one.
    const auto now = clock_.now();
    const auto wait = std::clamp<Clock::duration>(next - now, Clock::duration::zero(), options_.longest_wait);
    cv_.wait_for(lock, wait, [this] { return stopping_ || woken_ || !jobs_.empty(); });
    if (stopping_) return;
  }
}

}  // namespace rtukit
