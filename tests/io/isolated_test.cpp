#include "io/isolated.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <stdexcept>

namespace maps::io {
namespace {

TEST(Isolated, ReportsAReturnAThrowACrashAnExitAndAHang) {
  int touched = 0;
  IsolatedOutcome done = run_isolated([&touched] { touched = 1; }, 10);
  EXPECT_TRUE(done.finished);
  EXPECT_EQ(done.error, "");
  EXPECT_EQ(touched, 0) << "the child's memory is its own";

  IsolatedOutcome threw = run_isolated([] { throw std::runtime_error("bad file 'x.h5'"); }, 10);
  EXPECT_TRUE(threw.finished);
  EXPECT_EQ(threw.error, "bad file 'x.h5'");

  // A segfault kills the child, or, under AddressSanitizer (which catches SEGV), ends it with its report's exit status.
  IsolatedOutcome crashed = run_isolated([] { ::raise(SIGSEGV); }, 10);
  EXPECT_FALSE(crashed.finished);
  EXPECT_TRUE(crashed.signal == SIGSEGV || crashed.exit_status != 0) << crashed.signal << " " << crashed.exit_status;

  IsolatedOutcome killed = run_isolated([] { ::raise(SIGKILL); }, 10);
  EXPECT_FALSE(killed.finished);
  EXPECT_EQ(killed.signal, SIGKILL);

  // A sanitizer that finds an error in the child exits with 1: a crash, not a refusal.
  IsolatedOutcome exited = run_isolated([] { ::_exit(1); }, 10);
  EXPECT_FALSE(exited.finished);
  EXPECT_EQ(exited.exit_status, 1);

  IsolatedOutcome hung = run_isolated([] { ::pause(); }, 0.3);
  EXPECT_FALSE(hung.finished);
  EXPECT_TRUE(hung.timed_out);
  EXPECT_EQ(hung.signal, 0);
}

}  // namespace
}  // namespace maps::io
