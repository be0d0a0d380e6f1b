// TimelineJournalThread: the timeline journal's disk writes on a thread of
// their own, so that the bus's control thread never waits for the disk. Its
// LSS and SDO steps are timed (a Fastscan bit is decided by an answer within
// a few milliseconds, canopen/lss_master.hpp): a write in the middle of one,
// slow on a busy disk, would turn an answer into silence.
//
// The control thread notes each event (a lock and a copy) and hands the
// noted events over with the configured devices' timelines as they are
// (shared copies) at most once per TimelineJournal::kFlushInterval; the
// writer thread writes them (TimelineJournal::flush), syncing the file at
// most every TimelineJournal::kSyncInterval, logs a failure once per run of
// failures and keeps the events for the next hand-over. The destructor
// writes every event noted and syncs the file, then joins.
//
// Threads: note(), pending() and hand_over() on the bus's control thread;
// the writer thread owns the TimelineJournal.
#pragma once

#include "bus/timeline_journal.hpp"
#include "bus/timeline_sink.hpp"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace cobridge::bus {

class TimelineJournalThread final : public TimelineSink {
 public:
  // `journal`: loaded already (its history read by the caller); `bus`
  // names the bus in log lines.
  TimelineJournalThread(TimelineJournal journal, std::string bus);
  ~TimelineJournalThread() override;
  TimelineJournalThread(const TimelineJournalThread&) = delete;
  TimelineJournalThread& operator=(const TimelineJournalThread&) = delete;

  void note(const std::string& device, const TimelineEvent& e) override;
  [[nodiscard]] bool pending() const noexcept override { return pending_; }
  void hand_over(TimelineJournal::Devices devices) override;

 private:
  void run();
  // `last`: the stop; the file is synced then whatever the interval.
  void write(TimelineJournal::Queue events, const TimelineJournal::Devices& devices, bool last);

  TimelineJournal journal_;  // the writer thread's
  const std::string bus_;
  bool failing_ = false;  // the writer thread's: the last write failed
  std::chrono::steady_clock::time_point synced_at_{};  // the writer thread's: the last synced write
  bool pending_ = false;  // the control thread's: events noted since the last hand-over

  std::mutex mutex_;
  std::condition_variable wake_;
  TimelineJournal::Queue events_;     // noted, not yet taken by the writer
  TimelineJournal::Devices devices_;  // the latest hand-over's timelines (for compaction)
  bool handed_over_ = false;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace cobridge::bus
