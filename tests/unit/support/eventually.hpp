// eventually(): a test's wait for something another thread brings about,
// bounded, instead of a fixed sleep that hopes it has happened by then. The
// limit only costs time when the test fails, so it can be generous (a
// loaded machine is slow, not wrong).
//
// A test that asserts something does NOT happen needs a time window: it
// waits with eventually() for what makes the absence meaningful first, then
// sleeps a named window and says so.
//
// Included as "unit/support/eventually.hpp" (every test target has tests/
// on its include path).
#pragma once

#include <chrono>
#include <thread>

namespace cobridge::test {

// True as soon as `condition()` holds (checked every 1 ms); false when it
// still does not once `limit` has passed. The last check comes after the
// deadline, so a test thread descheduled past it sees a condition that holds.
template <class F>
bool eventually(F condition, std::chrono::milliseconds limit) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  for (;;) {
    if (condition()) return true;
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace cobridge::test
