#pragma once
// Progress reporting and cancellation for long operations. Thread-safe: parallel loops may
// call advance() from any thread.
#include <atomic>
#include <functional>
#include <mutex>
#include <string>

namespace vellum {

class Progress {
 public:
  /// Called with (stage, fraction in [0,1]); invoked from whichever thread reports, but
  /// serialised and rate-limited to changes of at least 0.5%.
  using Callback = std::function<void(const std::string& stage, double fraction)>;

  Progress() = default;
  explicit Progress(Callback cb) : callback_(std::move(cb)) {}

  /// Starts a stage of `totalUnits` work units (e.g. slices).
  void begin(const std::string& stage, uint64_t totalUnits);
  /// Adds finished units; throws vellum::Cancelled if cancellation was requested.
  void advance(uint64_t units = 1);
  /// Marks the current stage complete.
  void end();
  /// Throws vellum::Cancelled if cancellation was requested.
  void checkCancelled() const;

  void cancel() { cancelled_.store(true); }
  bool cancelled() const { return cancelled_.load() || cancelRequestedEverywhere(); }

  /// Cancels every Progress in the process (their next advance()/checkCancelled() throws).
  /// Async-signal-safe: the CLI calls it from its SIGINT/SIGTERM handler so that Ctrl-C
  /// unwinds through the atomic writers and leaves no temporary files behind.
  static void requestCancelEverywhere() noexcept;
  static bool cancelRequestedEverywhere() noexcept;
  double fraction() const;

  /// A do-nothing instance for callers that do not care.
  static Progress& none();

 private:
  Callback callback_;
  std::atomic<bool> cancelled_{false};
  std::atomic<uint64_t> done_{0};
  uint64_t total_ = 1;
  std::string stage_;
  std::mutex reportMutex_;
  double lastReported_ = -1;
};

}  // namespace vellum
