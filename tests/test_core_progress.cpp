// Tests for core/progress.hpp: ProgressCallback behaves as the std::function it replaces for
// every use in the library (empty by default and from nullptr, built from lambdas with state,
// copied with its state, moved, reassigned, called through report_progress).
#include <gtest/gtest.h>

#include <string>
#include <string_view>
#include <utility>

#include "btflod/core/progress.hpp"

namespace {

using btflod::ProgressCallback;

TEST(CoreProgress, EmptyCallbacksContinue) {
  ProgressCallback a;
  ProgressCallback b = nullptr;
  ProgressCallback c = {};
  EXPECT_FALSE(a);
  EXPECT_FALSE(b);
  EXPECT_FALSE(c);
  EXPECT_TRUE(btflod::report_progress(a, "stage", 0.5));
}

TEST(CoreProgress, CallsTheCallableWithItsArgumentsAndResult) {
  std::string seen;
  double last = -1;
  ProgressCallback cb = [&](std::string_view stage, double f) {
    seen = std::string(stage);
    last = f;
    return f < 0.5;
  };
  ASSERT_TRUE(cb);
  EXPECT_TRUE(btflod::report_progress(cb, "encode tiles", 0.25));
  EXPECT_EQ(seen, "encode tiles");
  EXPECT_EQ(last, 0.25);
  EXPECT_FALSE(cb("render", 0.75)) << "false requests cancellation";
  EXPECT_EQ(seen, "render");
}

TEST(CoreProgress, CopiesOwnTheirStateAndMovesTransferIt) {
  int calls = 0;
  ProgressCallback counting = [n = 0, &calls](std::string_view, double) mutable {
    ++n;
    calls = n;
    return true;
  };
  counting("a", 0);
  ProgressCallback copy = counting;  // copies n == 1
  copy("b", 0);
  EXPECT_EQ(calls, 2);
  counting("c", 0);
  EXPECT_EQ(calls, 2) << "the original's counter is its own";
  ProgressCallback moved = std::move(copy);
  EXPECT_TRUE(moved);
  moved("d", 0);
  EXPECT_EQ(calls, 3);
  moved = nullptr;
  EXPECT_FALSE(moved);
  moved = counting;
  EXPECT_TRUE(moved);
  const ProgressCallback& alias = moved;
  moved = alias;  // self-assignment keeps the callable
  EXPECT_TRUE(moved("e", 0));
}

}  // namespace
