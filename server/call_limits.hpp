// SPDX-License-Identifier: AGPL-3.0-or-later
// Bounds on what one client can hold on the coordinator's client port, which
// uses gRPC's synchronous API (one server thread per call in flight):
//  * CallWatchdog cancels a call that outlives its time (an upload that never
//    ends, a client that sends one byte a second), whatever deadline the
//    client set or did not set;
//  * StreamCounter caps the streaming calls (uploads, watches, downloads) one
//    user has open at once, so that one user cannot take every server thread,
//    and those of all users together, so that streams leave threads for the
//    short calls (get, list, cancel, delete).
// The server's total threads are capped by a grpc::ResourceQuota (coordinator.cpp);
// a call beyond it waits in gRPC's queue for a thread, so the stream cap is set
// below it (stream_limit_for_threads) and refuses streams with a status instead.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <thread>

namespace grpc {
class ServerContext;
}

namespace pdrmesh::server {

class CallWatchdog {
 public:
  CallWatchdog();
  ~CallWatchdog();  ///< joins the thread; no guard may outlive the watchdog
  CallWatchdog(const CallWatchdog&) = delete;
  CallWatchdog& operator=(const CallWatchdog&) = delete;

  /// While alive, the call is cancelled (ServerContext::TryCancel: its reads
  /// and writes fail) once `seconds` have passed.
  class Guard {
   public:
    Guard(CallWatchdog& dog, std::uint64_t id) : dog_(&dog), id_(id) {}
    Guard(const Guard&) = delete;
    Guard& operator=(const Guard&) = delete;
    ~Guard();
    /// True when the watchdog cancelled the call.
    bool fired() const;

   private:
    CallWatchdog* dog_;
    std::uint64_t id_;
  };
  Guard watch(grpc::ServerContext* context, double seconds);

 private:
  struct Entry {
    std::chrono::steady_clock::time_point deadline;
    grpc::ServerContext* context;
    bool fired = false;
  };
  void loop();

  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::map<std::uint64_t, Entry> calls_;
  std::uint64_t next_id_ = 0;
  bool stopping_ = false;
  std::thread thread_;
};

/// Streams of all users together on a server of `max_server_threads`: three
/// quarters of them (at least 1), the rest kept for short calls.
int stream_limit_for_threads(int max_server_threads);

class StreamCounter {
 public:
  StreamCounter(int max_per_user, int max_total) : max_(max_per_user), max_total_(max_total) {}

  /// One open stream of a user; released when destroyed.
  class Slot {
   public:
    Slot() = default;
    Slot(StreamCounter* counter, std::string user) : counter_(counter), user_(std::move(user)) {}
    Slot(Slot&& o) noexcept : counter_(o.counter_), user_(std::move(o.user_)) { o.counter_ = nullptr; }
    Slot& operator=(Slot&& o) noexcept {
      if (this != &o) {
        release();
        counter_ = o.counter_;
        user_ = std::move(o.user_);
        o.counter_ = nullptr;
      }
      return *this;
    }
    ~Slot() { release(); }
    explicit operator bool() const { return counter_ != nullptr; }

   private:
    void release() noexcept;
    StreamCounter* counter_ = nullptr;
    std::string user_;
  };
  /// Why try_open refused.
  enum class Full { kUser, kServer };
  /// A slot, or an empty one (and *why) when `user` has max_per_user streams
  /// open or all users together max_total.
  Slot try_open(const std::string& user, Full* why = nullptr);
  int max_per_user() const { return max_; }
  int max_total() const { return max_total_; }

 private:
  std::mutex mu_;
  std::map<std::string, int> open_;
  int total_ = 0;
  int max_;
  int max_total_;
};

}  // namespace pdrmesh::server
