#include "task_queue.hpp"

namespace vellum::studio {

void TaskQueue::push(std::string name, Work work) { queue_.emplace_back(std::move(name), std::move(work)); }

bool TaskQueue::poll(const std::function<void(const std::string&)>& onError) {
  bool applied = false;
  if (auto out = job_.take()) {
    const bool cancelled = job_.cancelled();
    if (cancelled) onError(running_ + " cancelled");  // its result (if it got one) is dropped
    else if (!out->error.empty()) onError(running_ + ": " + out->error);
    else if (out->apply) {
      try {
        out->apply();
        applied = true;
      } catch (const std::exception& e) {
        onError(running_ + ": " + e.what());
      }
    }
    running_.clear();
  }
  if (!job_.busy() && !job_.ready() && !queue_.empty()) {
    auto [name, work] = std::move(queue_.front());
    queue_.pop_front();
    running_ = name;
    job_.start([work = std::move(work)](Progress& p) { return Outcome{"", work(p)}; }, name);
  }
  return applied;
}

}  // namespace vellum::studio
