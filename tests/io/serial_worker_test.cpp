#include "stillmap/io/serial_worker.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <stdexcept>
#include <thread>
#include <vector>

namespace stillmap {
namespace {

TEST(SerialWorkerTest, RunsTheTasksInOrderOnOneThreadOfItsOwn) {
  SerialWorker worker;
  std::vector<int> order;  // written by the worker only, read after the futures
  std::vector<std::future<std::thread::id>> threads;
  threads.reserve(20);
  for (int i = 0; i < 20; ++i) {
    threads.push_back(worker.Submit([&order, i] {
      order.push_back(i);
      return std::this_thread::get_id();
    }));
  }
  std::vector<std::thread::id> ids;
  ids.reserve(threads.size());
  for (auto& thread : threads) ids.push_back(thread.get());
  for (int i = 0; i < 20; ++i) EXPECT_EQ(order[static_cast<size_t>(i)], i);
  for (const std::thread::id& id : ids) {
    EXPECT_EQ(id, ids.front());
    EXPECT_NE(id, std::this_thread::get_id());
  }
}

TEST(SerialWorkerTest, AnExceptionArrivesThroughItsFutureAndTheWorkerGoesOn) {
  SerialWorker worker;
  std::future<int> failing = worker.Submit([]() -> int { throw std::runtime_error("bad frame"); });
  std::future<int> next = worker.Submit([] { return 7; });
  EXPECT_THROW(failing.get(), std::runtime_error);
  EXPECT_EQ(next.get(), 7);
}

TEST(SerialWorkerTest, EndingRunsTheTasksStillQueued) {
  std::atomic<int> done{0};
  {
    SerialWorker worker;
    for (int i = 0; i < 10; ++i) {
      worker.Submit([&done] {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        ++done;
      });
    }
  }
  EXPECT_EQ(done.load(), 10);
}

}  // namespace
}  // namespace stillmap
