// Journal-native logging: under systemd every module logs journal
// entries with a priority, the module and the bus/node of the line, and no
// console pattern (time stamp, [module], [level]) inside MESSAGE=.
#include "sys/journal_sink.hpp"
#include "sys/logging.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <syslog.h>
#include <unistd.h>

#include <memory>
#include <string>
#include <vector>

using namespace cobridge::sys;
using ::testing::ElementsAre;

TEST(JournalSink, PriorityOfEachLevel) {
  EXPECT_EQ(journal_priority(spdlog::level::trace), LOG_DEBUG);
  EXPECT_EQ(journal_priority(spdlog::level::debug), LOG_DEBUG);
  EXPECT_EQ(journal_priority(spdlog::level::info), LOG_INFO);
  EXPECT_EQ(journal_priority(spdlog::level::warn), LOG_WARNING);
  EXPECT_EQ(journal_priority(spdlog::level::err), LOG_ERR);
  EXPECT_EQ(journal_priority(spdlog::level::critical), LOG_CRIT);
}

TEST(JournalSink, BusAndNodeFromTheBusManagersLines) {
  EXPECT_EQ(journal_bus("bus line1: device hoist (node 20) offline: heartbeat"), "line1");
  EXPECT_EQ(journal_node("bus line1: device hoist (node 20) offline: heartbeat"), "20");
  EXPECT_EQ(journal_node("bus l: device a operational at node 10 (12 ms, 3 writes, 0 saves)"), "10");
  EXPECT_EQ(journal_bus("bus l-2.x: serving vcan0"), "l-2.x");
  EXPECT_EQ(journal_node("bus l-2.x: serving vcan0"), "");
  // Prose is not a bus; a node-ID needs 1..3 digits.
  EXPECT_EQ(journal_bus("bus manager stopped: ok"), "");
  EXPECT_EQ(journal_bus("vcan0: opened (CAN_RAW, fd 3)"), "");
  EXPECT_EQ(journal_bus("bus : x"), "");
  EXPECT_EQ(journal_node("(node x)"), "");
  EXPECT_EQ(journal_node("(node 1234)"), "");
}

TEST(JournalSink, FieldsOfOneRecord) {
  EXPECT_THAT(journal_fields("cobridged", "gateway", spdlog::level::warn, "bus line1: device a (node 10) offline"),
              ElementsAre("MESSAGE=bus line1: device a (node 10) offline", "PRIORITY=4",
                          "SYSLOG_IDENTIFIER=cobridged", "COBRIDGE_MODULE=gateway", "BUS=line1", "NODE=10"));
  EXPECT_THAT(journal_fields("cobridged", "can", spdlog::level::info, "vcan0: opened (CAN_RAW, fd 3)"),
              ElementsAre("MESSAGE=vcan0: opened (CAN_RAW, fd 3)", "PRIORITY=6", "SYSLOG_IDENTIFIER=cobridged",
                          "COBRIDGE_MODULE=can"));
}

TEST(JournalSink, EveryModuleLoggerSendsTheBareMessage) {
  std::vector<std::vector<std::string>> sent;
  auto sink = std::make_shared<JournalSink>("cobridged", [&](const std::vector<std::string>& f) {
    sent.push_back(f);
    return 0;
  });
  spdlog::logger log("modbus", sink);
  log.set_level(spdlog::level::debug);
  log.error("listen on {}:{} failed: {} %s %n", "0.0.0.0", 1502, "Address in use");
  log.debug("trace line\n");
  ASSERT_EQ(sent.size(), 2U);
  // No time stamp, no [modbus], no [error]: the journal has those as fields.
  EXPECT_EQ(sent[0][0], "MESSAGE=listen on 0.0.0.0:1502 failed: Address in use %s %n");
  EXPECT_EQ(sent[0][1], "PRIORITY=3");
  EXPECT_EQ(sent[0][3], "COBRIDGE_MODULE=modbus");
  EXPECT_EQ(sent[1][0], "MESSAGE=trace line");
  EXPECT_EQ(sent[1][1], "PRIORITY=7");
}

TEST(JournalSink, StderrIsTheJournalOnlyWhenJournalStreamNamesIt) {
  struct stat st {};
  ASSERT_EQ(::fstat(STDERR_FILENO, &st), 0);
  const std::string mine = std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
  const char* saved = ::getenv("JOURNAL_STREAM");
  const std::string keep = saved ? saved : "";

  ::unsetenv("JOURNAL_STREAM");
  EXPECT_FALSE(stderr_is_journal());
  ::setenv("JOURNAL_STREAM", mine.c_str(), 1);
  EXPECT_TRUE(stderr_is_journal());
  // Inherited from a parent whose stderr was the journal, ours is not.
  ::setenv("JOURNAL_STREAM", (std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino + 1)).c_str(), 1);
  EXPECT_FALSE(stderr_is_journal());
  for (const char* bad : {"", ":", "12", "a:b", "1:2:3", "1:", ":2"}) {
    ::setenv("JOURNAL_STREAM", bad, 1);
    EXPECT_FALSE(stderr_is_journal()) << bad;
  }
  if (saved) ::setenv("JOURNAL_STREAM", keep.c_str(), 1);
  else ::unsetenv("JOURNAL_STREAM");
}

TEST(JournalSink, ModuleLoggersMadeLaterUseTheChosenSink) {
  // The "can" logger used to make its own console logger when it was first
  // used after setup: every module's logger must share the one sink.
  setup_logging(LogTarget::journal);
  auto late = logger("module-made-after-setup");
  ASSERT_EQ(late->sinks().size(), 1U);
  EXPECT_NE(std::dynamic_pointer_cast<JournalSink>(late->sinks()[0]), nullptr);
  setup_logging(LogTarget::console);
  EXPECT_EQ(std::dynamic_pointer_cast<JournalSink>(late->sinks()[0]), nullptr);
}
