#pragma once
// One piece of work on a worker thread, with progress and cancel, polled by the UI thread
// once per frame (loading a volume, evolving a snake ...). The UI adopts the result with
// take(), so the scene only changes on the UI thread.
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>

#include "vellum/core/error.hpp"
#include "thread_priority.hpp"
#include "vellum/core/progress.hpp"

namespace vellum::studio {

template <class Result>
class BackgroundJob {
 public:
  /// `failed(message)` makes the Result that reports an error ("<what> cancelled" on cancel).
  BackgroundJob(std::string what, std::function<Result(const std::string&)> failed)
      : what_(std::move(what)), failed_(std::move(failed)) {}
  ~BackgroundJob() {
    cancel();
    if (thread_.joinable()) thread_.join();
  }
  BackgroundJob(const BackgroundJob&) = delete;
  BackgroundJob& operator=(const BackgroundJob&) = delete;

  /// Runs work(progress) on the worker; false if a job is already running.
  bool start(std::function<Result(Progress&)> work, std::string firstStage) {
    std::lock_guard lock(mutex_);
    if (running_) return false;
    if (thread_.joinable()) thread_.join();
    running_ = true;
    result_.reset();
    stage_ = std::move(firstStage);
    fraction_ = 0;
    progress_ = std::make_unique<Progress>([this](const std::string& stage, double f) {
      std::lock_guard l(mutex_);
      stage_ = stage;
      fraction_ = f;
    });
    thread_ = std::thread([this, work = std::move(work)] {
      lowerThreadPriority();  // the window's frames come first
      Result r;
      try {
        r = inWorkerArena([&] { return work(*progress_); });
      } catch (const Cancelled&) {
        r = failed_(what_ + " cancelled");
      } catch (const std::exception& e) {
        r = failed_(e.what());
      }
      std::lock_guard l(mutex_);
      result_ = std::move(r);
      running_ = false;
    });
    return true;
  }
  bool busy() const {
    std::lock_guard lock(mutex_);
    return running_;
  }
  /// A finished result waits for take().
  bool ready() const {
    std::lock_guard lock(mutex_);
    return !running_ && result_.has_value();
  }
  /// Blocks until the running job (if any) has finished; its result stays for take().
  void wait() {
    std::thread t;
    {
      std::lock_guard lock(mutex_);
      t = std::move(thread_);
    }
    if (t.joinable()) t.join();
  }
  /// Stage and fraction of the running job.
  std::pair<std::string, double> progress() const {
    std::lock_guard lock(mutex_);
    return {stage_, fraction_};
  }
  void cancel() {
    std::lock_guard lock(mutex_);
    if (running_ && progress_) progress_->cancel();
  }
  /// True when cancel() was asked of the running or last job.
  bool cancelled() const {
    std::lock_guard lock(mutex_);
    return progress_ && progress_->cancelled();
  }
  /// The finished result, once; nullopt while running or idle.
  std::optional<Result> take() {
    std::lock_guard lock(mutex_);
    if (running_ || !result_) return std::nullopt;
    std::optional<Result> r = std::move(result_);
    result_.reset();
    return r;
  }

 private:
  std::string what_;
  std::function<Result(const std::string&)> failed_;
  mutable std::mutex mutex_;
  std::thread thread_;
  std::unique_ptr<Progress> progress_;
  std::string stage_;
  double fraction_ = 0;
  bool running_ = false;
  std::optional<Result> result_;
};

}  // namespace vellum::studio
