// SPDX-License-Identifier: AGPL-3.0-or-later
// CallWatchdog and StreamCounter (see call_limits.hpp).
#include "call_limits.hpp"

#include <algorithm>

#include <grpcpp/server_context.h>

namespace pdrmesh::server {

CallWatchdog::CallWatchdog() : thread_([this] { loop(); }) {}

CallWatchdog::~CallWatchdog() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

CallWatchdog::Guard CallWatchdog::watch(grpc::ServerContext* context, double seconds) {
  std::uint64_t id = 0;
  {
    std::lock_guard lock(mu_);
    id = next_id_++;
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(seconds));
    calls_.emplace(id, Entry{deadline, context});
  }
  cv_.notify_all();
  return Guard(*this, id);
}

CallWatchdog::Guard::~Guard() {
  std::lock_guard lock(dog_->mu_);
  dog_->calls_.erase(id_);
}

bool CallWatchdog::Guard::fired() const {
  std::lock_guard lock(dog_->mu_);
  const auto it = dog_->calls_.find(id_);
  return it != dog_->calls_.end() && it->second.fired;
}

void CallWatchdog::loop() {
  std::unique_lock lock(mu_);
  while (!stopping_) {
    auto next = std::chrono::steady_clock::time_point::max();
    const auto now = std::chrono::steady_clock::now();
    for (auto& [id, e] : calls_) {
      if (e.fired) continue;
      if (e.deadline <= now) {
        e.fired = true;
        e.context->TryCancel();  // the guard's call is still running: its context is alive
      } else {
        next = std::min(next, e.deadline);
      }
    }
    if (next == std::chrono::steady_clock::time_point::max()) {
      cv_.wait(lock);
    } else {
      cv_.wait_until(lock, next);
    }
  }
}

int stream_limit_for_threads(int max_server_threads) {
  return std::max(1, max_server_threads - std::max(2, max_server_threads / 4));
}

StreamCounter::Slot StreamCounter::try_open(const std::string& user, Full* why) {
  std::lock_guard lock(mu_);
  const auto it = open_.find(user);
  const bool user_full = it != open_.end() && it->second >= max_;
  if (user_full || total_ >= max_total_) {
    if (why != nullptr) *why = user_full ? Full::kUser : Full::kServer;
    return {};
  }
  ++open_[user];
  ++total_;
  return Slot(this, user);
}

void StreamCounter::Slot::release() noexcept {
  if (counter_ == nullptr) return;
  std::lock_guard lock(counter_->mu_);
  if (--counter_->open_[user_] == 0) counter_->open_.erase(user_);
  --counter_->total_;
  counter_ = nullptr;
}

}  // namespace pdrmesh::server
