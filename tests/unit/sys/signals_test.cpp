// Signals through signalfd: SIGHUP asks for a reload, SIGTERM/SIGINT for a stop,
// and stop wins when both are pending (a reload must not delay a shutdown).
#include "sys/signals.hpp"

#include <gtest/gtest.h>

#include <csignal>

using cobridge::sys::SignalAction;
using cobridge::sys::Signals;

TEST(Signals, HupIsReloadTermIsStop) {
  Signals s;
  ASSERT_FALSE(s.error());
  ASSERT_GE(s.fd(), 0);
  EXPECT_EQ(s.take(), SignalAction::none);
  ASSERT_EQ(::raise(SIGHUP), 0);
  EXPECT_EQ(s.take(), SignalAction::reload);
  ASSERT_EQ(::raise(SIGTERM), 0);
  EXPECT_EQ(s.take(), SignalAction::stop);
  ASSERT_EQ(::raise(SIGINT), 0);
  EXPECT_EQ(s.take(), SignalAction::stop);
}

TEST(Signals, StopWinsOverPendingReload) {
  Signals s;
  ASSERT_EQ(::raise(SIGHUP), 0);
  ASSERT_EQ(::raise(SIGTERM), 0);
  EXPECT_EQ(s.take(), SignalAction::stop);
  EXPECT_EQ(s.take(), SignalAction::none);
}
