// One thread that runs the tasks handed to it, in the order given: for work that recurs beside
// the caller (a detector run every other frame) without starting and ending a thread each time.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>
#include <type_traits>
#include <utility>

namespace stillmap {

class SerialWorker {
 public:
  SerialWorker();
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;
  ~SerialWorker();  // runs the tasks still queued, then ends the thread

  // Queues `task`; its result (or exception) arrives through the future.
  template <typename Task>
  std::future<std::invoke_result_t<Task>> Submit(Task task) {
    using Result = std::invoke_result_t<Task>;
    auto packaged = std::make_shared<std::packaged_task<Result()>>(std::move(task));
    std::future<Result> result = packaged->get_future();
    Enqueue([packaged] { (*packaged)(); });
    return result;
  }

 private:
  void Enqueue(std::function<void()> task);
  void Loop();

  std::mutex mutex_;
  std::condition_variable changed_;  // a task queued, or stopping
  std::deque<std::function<void()>> tasks_;
  bool stopping_ = false;
  std::thread thread_;  // last: started once the members it uses exist
};

}  // namespace stillmap
