#pragma once
// The studio's edits that can take long on a real scan (label operations, label files, the
// scene file) queued for one worker, in order, each on BackgroundJob with progress and
// cancel. A task's work runs on the worker and returns what the UI thread then applies (one
// closure, run by poll()), so the document only changes on the UI thread and the window keeps
// drawing while the work runs. A request made while a task runs is queued behind it, never
// dropped; the UI shows what runs and how many wait.
#include <deque>
#include <functional>
#include <string>
#include <utility>

#include "background_job.hpp"

namespace vellum::studio {

class TaskQueue {
 public:
  /// What the UI thread does with a finished task's result (may be empty).
  using Apply = std::function<void()>;
  /// The worker's part: reads what it needs (the document is not changed meanwhile: see
  /// StudioApp::labelsFrozen) and returns the UI thread's part.
  using Work = std::function<Apply(Progress&)>;

  /// Queues `work` under `name` ("remove islands", "saving labels"); it starts at the next
  /// poll() once the tasks before it are done.
  void push(std::string name, Work work);
  /// UI thread, once per frame: applies a finished task (its error or "<name> cancelled" goes
  /// to `onError`) and starts the next queued one. Returns true when a task was applied.
  bool poll(const std::function<void(const std::string&)>& onError);
  /// A task runs or waits.
  bool busy() const { return job_.busy() || job_.ready() || !queue_.empty(); }
  /// The running task's name ("" when none), its stage and fraction, and how many wait.
  const std::string& running() const { return running_; }
  std::pair<std::string, double> progress() const { return job_.progress(); }
  size_t waiting() const { return queue_.size(); }
  /// Cancels the running task (its result is dropped); the waiting ones still run.
  void cancel() { job_.cancel(); }
  /// Drops the waiting tasks (not the running one).
  void clearWaiting() { queue_.clear(); }
  /// Blocks until the running task has finished (quitting: nothing is applied any more).
  void wait() { job_.wait(); }

 private:
  struct Outcome {
    std::string error;
    Apply apply;
  };
  std::deque<std::pair<std::string, Work>> queue_;
  std::string running_;
  BackgroundJob<Outcome> job_{"task", [](const std::string& error) { return Outcome{error, {}}; }};
};

}  // namespace vellum::studio
