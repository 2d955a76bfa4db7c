// The memory budget the workers share: reservations that fit are granted at once, one that does not waits for a
// release, a wait gives up when asked, and a reservation larger than the budget runs alone rather than never.
#include "daemon/memory_budget.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace kiln::daemon {
namespace {

TEST(MemoryBudget, WhatFitsIsGrantedAndWhatDoesNotWaitsForARelease) {
  MemoryBudget b(100);
  ASSERT_TRUE(b.reserve(60, {}));
  EXPECT_EQ(b.in_use(), 60u);
  std::atomic<bool> granted{false};
  std::thread second([&] {
    b.reserve(60, {});
    granted = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(granted) << "60 + 60 > 100";
  b.release(60);
  second.join();
  EXPECT_TRUE(granted);
  EXPECT_EQ(b.in_use(), 60u);
  b.release(60);
  EXPECT_EQ(b.in_use(), 0u);
}

TEST(MemoryBudget, AWaitGivesUpWhenAsked) {
  MemoryBudget b(100);
  ASSERT_TRUE(b.reserve(80, {}));
  std::atomic<bool> stop{false};
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(150));
    stop = true;
  });
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(b.reserve(80, [&] { return stop.load(); }));
  // Polled every 100 ms: it ends within that of the request (300 ms allows for a loaded machine).
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(450));
  stopper.join();
  EXPECT_EQ(b.in_use(), 80u);
}

TEST(MemoryBudget, AReservationLargerThanTheBudgetRunsAlone) {
  MemoryBudget b(100);
  ASSERT_TRUE(b.reserve(10, {}));
  EXPECT_FALSE(b.reserve(500, [] { return true; })) << "not beside another";
  b.release(10);
  EXPECT_TRUE(b.reserve(500, [] { return true; })) << "alone";
  EXPECT_FALSE(b.reserve(1, [] { return true; }));
  {
    const MemoryReservation r(b, 500);  // hands the 500 back at the end of the scope
  }
  EXPECT_TRUE(b.reserve(100, {}));
}

}  // namespace
}  // namespace kiln::daemon
