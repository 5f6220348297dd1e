// The chains of a calibration run together in one process, each on its own
// thread, their emulator predictions made in step: when every running chain
// has asked for its sites' predictions (at its own inputs), the team
// evaluates each emulator bank at all of the chains' inputs at once
// (GaspBank::predict_many()), the banks shared out among the chains'
// threads. Each coefficient's weights and each packed factor are then read
// from memory once per cycle for all the chains, where chains in processes
// of their own each stream them. Every number is the one a chain computes
// alone (predict_many() gives predict_into()'s numbers to the bit), so the
// draws do not depend on whether the chains ran together.
#ifndef WAVEVALID_SAMPLER_TEAM_H
#define WAVEVALID_SAMPLER_TEAM_H

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>
#include "gasp_predict.h"

namespace wavevalid {

// Thrown in a chain of a team whose other chain has failed.
struct TeamStopped : public std::exception {
  const char* what() const noexcept override { return "another chain of the team stopped"; }
};

// What one bank group of one chain adds to a batch: the sites' inputs,
// outputs and workspaces (SamplerState::team_group()).
struct BankCall {
  const GaspBank* bank = nullptr;
  std::vector<const Eigen::VectorXd*> z;
  std::vector<Eigen::VectorXd*> m, v;
  std::vector<GaspBank::Workspace*> ws;
  void clear() {
    z.clear();
    m.clear();
    v.clear();
    ws.clear();
  }
};

class PredictTeam {
 public:
  // `fill(chain, g, call)` appends chain `chain`'s sites of bank group g to
  // `call` (its request is pending); `n_items` bank groups, the same for
  // every chain.
  using Fill = std::function<void(int, int, BankCall&)>;

  PredictTeam(int chains, int n_items, Fill fill)
      : active_(chains), items_(n_items), fill_(std::move(fill)), calls_(n_items) {}

  // Chain c's predictions: waits until every running chain has asked, then
  // takes its share of the banks, and returns when all are done.
  void predict(int c) {
    std::unique_lock<std::mutex> lk(mu_);
    if (stopped_) throw TeamStopped();
    pending_.push_back(c);
    const long mine = started_ + 1;  // the batch that will hold this request
    if (static_cast<int>(pending_.size()) == active_) {
      start_batch();
    } else {
      wait(lk, [&] { return stopped_ || started_.load() >= mine; });
      if (stopped_) throw TeamStopped();
    }
    lk.unlock();
    work();
    lk.lock();
    if (--working_ == 0) {
      finished_.store(mine);
      cv_.notify_all();
    } else {
      wait(lk, [&] { return stopped_ || finished_.load() >= mine; });
      if (stopped_ && finished_.load() < mine) throw TeamStopped();
    }
  }

  // Chain c has finished: it is no longer waited for.
  void leave() {
    std::lock_guard<std::mutex> lk(mu_);
    active_ -= 1;
    if (!pending_.empty() && static_cast<int>(pending_.size()) == active_) start_batch();
  }

  // A chain failed: every chain waiting, or asking later, stops.
  void stop() {
    std::lock_guard<std::mutex> lk(mu_);
    stopped_ = true;
    cv_.notify_all();
  }

 private:
  // under the lock: the pending requests become the batch
  void start_batch() {
    batch_.assign(pending_.begin(), pending_.end());
    std::sort(batch_.begin(), batch_.end());
    pending_.clear();
    working_ = static_cast<int>(batch_.size());
    next_.store(0);
    started_.store(started_.load() + 1);
    cv_.notify_all();
  }

  // The banks of the batch, taken one at a time by whichever thread is free.
  void work() {
    for (;;) {
      const int g = next_.fetch_add(1);
      if (g >= items_) return;
      BankCall& call = calls_[g];
      call.clear();
      for (int c : batch_) fill_(c, g, call);
      if (call.z.size() == 1) {
        call.bank->predict_into(*call.z[0], *call.m[0], *call.v[0], *call.ws[0], true);
      } else {
        call.bank->predict_many(call.z, call.m, call.v, call.ws);
      }
    }
  }

  // A short spin before sleeping (yielding the core to any other thread that
  // wants it): a cycle of a large problem takes about a millisecond, and a
  // sleeping thread takes tens of microseconds to wake. `ready` reads atomics
  // only; they change under the lock, so the sleep misses no wake-up.
  template <class Pred>
  void wait(std::unique_lock<std::mutex>& lk, Pred ready) {
    if (ready()) return;
    lk.unlock();
    for (int i = 0; i < 4000 && !ready(); ++i) std::this_thread::yield();
    lk.lock();
    cv_.wait(lk, ready);
  }

  int active_;
  const int items_;
  Fill fill_;
  std::vector<BankCall> calls_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<int> pending_, batch_;
  int working_ = 0;
  std::atomic<long> started_{0}, finished_{0};
  std::atomic<int> next_{0};
  std::atomic<bool> stopped_{false};
};

}  // namespace wavevalid

#endif
