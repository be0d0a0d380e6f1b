// /metrics: the Prometheus text format (exposition format 0.0.4), checked
// by the format's own linter, `promtool check metrics` (Debian's prometheus
// package), and the conventional names and labels Prometheus asks for.
#include "web/metrics.hpp"

#include "web_fixture.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>
#include <filesystem>
#include <fstream>
#include <string>

using cobridge::web::render_metrics;
using ::testing::HasSubstr;

namespace {

TEST(Metrics, ConventionalNamesAndLabels) {
  const std::string m = render_metrics(cobridge::web::test::sample_report(2, 2));
  EXPECT_THAT(m, HasSubstr("# TYPE cobridge_frames_received_total counter\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_frames_received_total{bus=\"line1\",socket=\"hot_path\"} 50000\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_device_up{bus=\"line2\",node=\"2\",name=\"enc-1-1\"} 0\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_device_up{bus=\"line2\",node=\"1\",name=\"enc-1-0\"} 1\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_value_age_seconds{bus=\"line2\",node=\"1\",name=\"enc-1-0\"} 0.05\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_value_stale{bus=\"line2\",node=\"2\",name=\"enc-1-1\"} 1\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_position{bus=\"line2\",node=\"1\",name=\"enc-1-0\",unit=\"deg\"} 12.5\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_device_state{bus=\"line2\",node=\"2\",name=\"enc-1-1\",state=\"offline\"} 1\n"));
  // Arrival histograms (Prometheus exposition format: cumulative buckets,
  // le labels, _sum and _count).
  EXPECT_THAT(m, HasSubstr("# TYPE cobridge_heartbeat_interval_seconds histogram\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_heartbeat_interval_seconds_bucket{bus=\"line2\",node=\"1\",name=\"enc-1-0\","
                           "le=\"0.05\"} 0\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_heartbeat_interval_seconds_bucket{bus=\"line2\",node=\"1\",name=\"enc-1-0\","
                           "le=\"0.1\"} 20\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_heartbeat_interval_seconds_bucket{bus=\"line2\",node=\"1\",name=\"enc-1-0\","
                           "le=\"0.5\"} 21\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_heartbeat_interval_seconds_bucket{bus=\"line2\",node=\"1\",name=\"enc-1-0\","
                           "le=\"+Inf\"} 21\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_heartbeat_interval_seconds_sum{bus=\"line2\",node=\"1\",name=\"enc-1-0\"} 2.3\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_heartbeat_interval_seconds_count{bus=\"line2\",node=\"1\",name=\"enc-1-0\"} 21\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_tpdo_interval_seconds_count{bus=\"line2\",node=\"1\",name=\"enc-1-0\"} 200\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_bus_controller_state{bus=\"line1\",state=\"error-active\"} 1\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_bus_controller_errors{bus=\"line1\",direction=\"tx\"} 12\n"));
  // Label values escaped as the format says.
  EXPECT_THAT(m, HasSubstr("name=\"odd \\\"name\\\\\""));
  // Every place a frame or sample can be lost has a counter.
  for (const char* lost : {"cobridge_kernel_drops_total", "cobridge_ring_drops_total",
                           "cobridge_status_event_drops_total", "cobridge_unknown_node_frames_total",
                           "cobridge_bad_length_frames_total", "cobridge_tx_dropped_total"})
    EXPECT_THAT(m, HasSubstr(std::string("# TYPE ") + lost + " counter\n")) << lost;
}

// What each output reports of itself (ABI 3 stats), one
// family per figure with an `output` label per instance.
TEST(Metrics, OutputFiguresAreOneFamilyPerName) {
  const std::string m = render_metrics(cobridge::web::test::sample_report(1, 1));
  EXPECT_THAT(m, HasSubstr("# TYPE cobridge_output_modbus_clients_connected gauge\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_output_modbus_clients_connected{output=\"modbus\",type=\"modbus\"} 3\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_output_modbus_clients_connected{output=\"modbus_scada2\",type=\"modbus\"} 3\n"));
  EXPECT_THAT(m, HasSubstr("# TYPE cobridge_output_modbus_requests_total counter\n"));
  EXPECT_THAT(m, HasSubstr("cobridge_output_up{output=\"dds\",type=\"dds\"} 0\n"));
  EXPECT_EQ(m.find("# TYPE cobridge_output_modbus_clients_connected"),
            m.rfind("# TYPE cobridge_output_modbus_clients_connected"))
      << "one TYPE line per family";
}

// Runs promtool on the text; returns its exit status and output.
int promtool(const std::string& text, std::string& output) {
  const auto file = std::filesystem::temp_directory_path() / ("cobridge-metrics-" + std::to_string(::getpid()));
  std::ofstream(file) << text;
  const std::string cmd = "promtool check metrics < " + file.string() + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return -1;
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) output += buf;
  const int rc = ::pclose(p);
  std::filesystem::remove(file);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

TEST(Metrics, PromtoolAcceptsThem) {
  ASSERT_EQ(::system("command -v promtool > /dev/null"), 0) << "promtool missing: scripts/setup-deps installs prometheus";
  for (const auto& [buses, devices] : {std::pair{0, 0}, std::pair{1, 1}, std::pair{4, 32}}) {
    std::string out;
    const int rc = promtool(render_metrics(cobridge::web::test::sample_report(buses, devices)), out);
    EXPECT_EQ(rc, 0) << buses << "x" << devices << ": " << out;
    EXPECT_EQ(out, "") << buses << "x" << devices;  // no lint warning either
  }
}

}  // namespace

namespace {

// The target, p99 <= 20 ms with 4 buses x 32 devices: the CPU part of
// an answer (the status JSON and the metrics text of a fresh snapshot), on
// the host. Prints the figures (docs/performance.md "Web service").
TEST(Metrics, FourBusesOf32DevicesRenderEveryDevice) {
  const auto report = cobridge::web::test::sample_report(4, 32);
  std::vector<double> ms;
  std::size_t bytes = 0;
  for (int i = 0; i < 200; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string json = cobridge::control::to_json(report);
    const std::string text = render_metrics(report);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    bytes = json.size() + text.size();
  }
  std::sort(ms.begin(), ms.end());
  // The time is a figure (target p99 <= 20 ms), printed, not asserted: under
  // the sanitizers this test measures the sanitizer.
  std::printf("FIGURE 4x32 devices: status JSON + metrics render p50 %.3f ms, p99 %.3f ms (%zu bytes)\n", ms[100],
              ms[197], bytes);
  const std::string text = render_metrics(report);
  std::size_t up = 0;
  for (std::size_t at = text.find("\ncobridge_device_up{"); at != std::string::npos;
       at = text.find("\ncobridge_device_up{", at + 1))
    ++up;
  EXPECT_EQ(up, 4u * 32u) << "every device of every bus has its up metric";
}

}  // namespace
