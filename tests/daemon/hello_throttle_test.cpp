// The throttle on failed hellos: the wait doubles with each failure from one address, is bounded, forgets after its
// window, keeps addresses apart, and remembers a bounded number of them.
#include "daemon/hello_throttle.h"

#include <gtest/gtest.h>

namespace kiln::daemon {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

TEST(HelloThrottle, WaitDoublesPerFailureUpToTheBound) {
  HelloThrottle t({milliseconds(50), milliseconds(5000), seconds(60), 16});
  const auto now = HelloThrottle::Clock::now();
  const long expected[] = {50, 100, 200, 400, 800, 1600, 3200, 5000, 5000};
  for (long e : expected) EXPECT_EQ(t.failed("10.0.0.1", now).count(), e);
  for (int i = 0; i < 10000; ++i) t.failed("10.0.0.1", now);  // no overflow however many pile up
  EXPECT_EQ(t.failed("10.0.0.1", now).count(), 5000);
}

TEST(HelloThrottle, AddressesAreCountedApartAndForgottenAfterTheWindow) {
  HelloThrottle t({milliseconds(50), milliseconds(5000), seconds(60), 16});
  const auto now = HelloThrottle::Clock::now();
  for (int i = 0; i < 5; ++i) t.failed("10.0.0.1", now);
  EXPECT_EQ(t.failed("10.0.0.2", now).count(), 50);                     // another address starts afresh
  EXPECT_EQ(t.failed("10.0.0.1", now + seconds(59)).count(), 1600);     // still within the window
  EXPECT_EQ(t.failed("10.0.0.1", now + seconds(59 + 61)).count(), 50);  // a quiet minute: forgotten
}

TEST(HelloThrottle, RemembersABoundedNumberOfAddresses) {
  HelloThrottle t({milliseconds(50), milliseconds(5000), seconds(60), 8});
  const auto now = HelloThrottle::Clock::now();
  for (int i = 0; i < 100; ++i) t.failed("10.0.1." + std::to_string(i), now + milliseconds(i));
  EXPECT_LE(t.peers(), 8u);
}

}  // namespace
}  // namespace kiln::daemon
