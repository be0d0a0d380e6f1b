#include "bus/timeline_journal_thread.hpp"

#include "sys/logging.hpp"

#include <utility>

namespace cobridge::bus {

TimelineJournalThread::TimelineJournalThread(TimelineJournal journal, std::string bus)
    : journal_(std::move(journal)), bus_(std::move(bus)), thread_([this] { run(); }) {}

TimelineJournalThread::~TimelineJournalThread() {
  {
    const std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void TimelineJournalThread::note(const std::string& device, const TimelineEvent& e) {
  const std::lock_guard lock(mutex_);
  TimelineJournal::queue_event(events_, device, e);
  pending_ = true;
}

void TimelineJournalThread::hand_over(TimelineJournal::Devices devices) {
  {
    const std::lock_guard lock(mutex_);
    devices_ = std::move(devices);
    handed_over_ = true;
  }
  pending_ = false;
  wake_.notify_one();
}

void TimelineJournalThread::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return handed_over_ || stop_; });
    // At the stop: what was noted after the last hand-over is written too,
    // and what is in the page cache goes to the disk.
    if (!handed_over_ && events_.empty()) {
      lock.unlock();
      (void)journal_.sync();
      return;
    }
    TimelineJournal::Queue events = std::exchange(events_, {});
    const TimelineJournal::Devices devices = devices_;  // kept: a later stop may still need them
    handed_over_ = false;
    const bool last = stop_;
    lock.unlock();
    write(std::move(events), devices, last);
    lock.lock();
  }
}

void TimelineJournalThread::write(TimelineJournal::Queue events, const TimelineJournal::Devices& devices,
                                  bool last) {
  for (const auto& [device, e] : events) journal_.note(device, e);
  const auto now = std::chrono::steady_clock::now();
  const bool sync = last || now - synced_at_ >= TimelineJournal::kSyncInterval;
  const Error err = journal_.flush(devices, sync);
  if (!err && sync) synced_at_ = now;
  const auto log = sys::logger("gateway");
  if (err && !failing_) log->warn("bus {}: timeline journal not written: {}", bus_, err.to_string());
  if (!err && failing_) log->info("bus {}: timeline journal written again", bus_);
  failing_ = static_cast<bool>(err);
}

}  // namespace cobridge::bus
