#include "encoder/motion.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <optional>
#include <utility>
#include <vector>

namespace cobridge::sim {
namespace {

class MotionCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "motion"; }
  std::string message(int ev) const override {
    switch (static_cast<MotionError>(ev)) {
      case MotionError::ok: return "ok";
      case MotionError::empty_spec: return "empty motion spec";
      case MotionError::unknown_kind: return "unknown motion kind";
      case MotionError::bad_number: return "not a number";
      case MotionError::wrong_field_count: return "wrong number of fields";
      case MotionError::bad_step: return "malformed step (expected <seconds>=<turns>)";
      case MotionError::not_increasing: return "times must be strictly increasing";
      case MotionError::bad_period: return "period must be > 0";
      case MotionError::bad_ramp: return "ramp needs turns_per_s > 0 and max_turns != 0";
      case MotionError::cannot_read_script: return "cannot read motion script";
      case MotionError::bad_script_line: return "malformed script line (expected <seconds> <turns>)";
      case MotionError::empty_script: return "motion script has no points";
    }
    return "unknown motion error";
  }
};

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool to_double(std::string_view text, double& out) noexcept {
  text = trim(text);
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc{} && ptr == end && std::isfinite(out);
}

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> parts;
  for (;;) {
    const auto pos = s.find(sep);
    parts.push_back(s.substr(0, pos));
    if (pos == std::string_view::npos) return parts;
    s.remove_prefix(pos + 1);
  }
}

MotionParseResult fail(MotionError e, std::string message) {
  MotionParseResult r;
  r.error = Error(Errc::kInvalidArgument, std::move(message), {}, make_error_code(e));
  return r;
}

// Value of a piecewise curve; `linear` interpolates, otherwise it holds the
// value of the last point at or before `t`.
double piecewise(const std::vector<std::pair<double, double>>& pts, double t, bool linear) noexcept {
  if (pts.empty()) return 0.0;
  if (t <= pts.front().first) return pts.front().second;
  const auto it = std::upper_bound(pts.begin(), pts.end(), t,
                                   [](double v, const std::pair<double, double>& p) { return v < p.first; });
  const auto& before = *(it - 1);
  if (it == pts.end() || !linear) return before.second;
  const double f = (t - before.first) / (it->first - before.first);
  return before.second + f * (it->second - before.second);
}

using Points = std::vector<std::pair<double, double>>;

std::string number_error(std::string_view field, std::string_view what, double& out) {
  if (to_double(field, out)) return {};
  return std::string(what) + " '" + std::string(field) + "' is not a number";
}

// steps:<t0>=<turns0>;<t1>=<turns1>;... into `points`; the failure, if any.
std::optional<MotionParseResult> parse_steps(std::string_view rest, Points& points) {
  if (trim(rest).empty()) return fail(MotionError::wrong_field_count, "steps: expected steps:<t0>=<turns0>;...");
  for (std::string_view item : split(rest, ';')) {
    item = trim(item);
    if (item.empty()) continue;  // tolerate a trailing ';'
    const auto eq = item.find('=');
    if (eq == std::string_view::npos)
      return fail(MotionError::bad_step, "steps: '" + std::string(item) + "' is not <seconds>=<turns>");
    double t = 0.0;
    double v = 0.0;
    if (auto msg = number_error(item.substr(0, eq), "steps: time", t); !msg.empty()) return fail(MotionError::bad_number, msg);
    if (auto msg = number_error(item.substr(eq + 1), "steps: turns", v); !msg.empty()) return fail(MotionError::bad_number, msg);
    if (!points.empty() && !(t > points.back().first))
      return fail(MotionError::not_increasing, "steps: time in '" + std::string(item) + "' is not after the previous step");
    points.emplace_back(t, v);
  }
  if (points.empty()) return fail(MotionError::wrong_field_count, "steps: no steps given");
  return std::nullopt;
}

// script:<path>: one "<seconds> <turns>" per line, '#' comments; the failure, if any.
std::optional<MotionParseResult> parse_script(std::string_view rest, Points& points) {
  const std::string path(trim(rest));
  if (path.empty()) return fail(MotionError::wrong_field_count, "script: expected script:<path>");
  std::ifstream in(path);
  if (!in) return fail(MotionError::cannot_read_script, "script: cannot open '" + path + "'");
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::string_view l = line;
    if (const auto hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
    l = trim(l);
    if (l.empty()) continue;
    const auto ws = l.find_first_of(" \t");
    const std::string where = "script: " + path + ":" + std::to_string(line_no) + ": '" + std::string(l) + "'";
    if (ws == std::string_view::npos) return fail(MotionError::bad_script_line, where + " needs <seconds> <turns>");
    double t = 0.0;
    double v = 0.0;
    if (!to_double(l.substr(0, ws), t) || !to_double(l.substr(ws + 1), v))
      return fail(MotionError::bad_script_line, where + " is not two numbers");
    if (!points.empty() && !(t > points.back().first))
      return fail(MotionError::not_increasing, where + " is not after the previous line");
    points.emplace_back(t, v);
  }
  if (points.empty()) return fail(MotionError::empty_script, "script: '" + path + "' has no points");
  return std::nullopt;
}

}  // namespace

const std::error_category& motion_category() noexcept {
  static const MotionCategory category;
  return category;
}

std::error_code make_error_code(MotionError e) noexcept {
  return {static_cast<int>(e), motion_category()};
}

MotionParseResult Motion::parse(std::string_view spec) {
  spec = trim(spec);
  if (spec.empty()) return fail(MotionError::empty_spec, "motion spec is empty");
  const auto colon = spec.find(':');
  const std::string_view kind = spec.substr(0, colon);
  const std::string_view rest = colon == std::string_view::npos ? std::string_view{} : spec.substr(colon + 1);

  Motion m;
  m.spec_ = std::string(spec);
  const auto number = [](std::string_view field, std::string_view what, double& out) -> std::string {
    if (to_double(field, out)) return {};
    return std::string(what) + " '" + std::string(field) + "' is not a number";
  };

  if (kind == "constant") {
    const auto f = split(rest, ':');
    if (colon == std::string_view::npos || f.size() != 1)
      return fail(MotionError::wrong_field_count, "constant: expected constant:<turns_per_s>");
    if (auto msg = number(f[0], "constant: turns_per_s", m.a_); !msg.empty()) return fail(MotionError::bad_number, msg);
    m.kind_ = Kind::constant;
  } else if (kind == "sine") {
    const auto f = split(rest, ':');
    if (colon == std::string_view::npos || f.size() < 2 || f.size() > 3)
      return fail(MotionError::wrong_field_count, "sine: expected sine:<amplitude_turns>:<period_s>[:<offset_turns>]");
    if (auto msg = number(f[0], "sine: amplitude", m.a_); !msg.empty()) return fail(MotionError::bad_number, msg);
    if (auto msg = number(f[1], "sine: period", m.b_); !msg.empty()) return fail(MotionError::bad_number, msg);
    if (f.size() == 3) {
      if (auto msg = number(f[2], "sine: offset", m.c_); !msg.empty()) return fail(MotionError::bad_number, msg);
    }
    if (!(m.b_ > 0.0)) return fail(MotionError::bad_period, "sine: period '" + std::string(f[1]) + "' must be > 0");
    m.kind_ = Kind::sine;
  } else if (kind == "steps") {
    if (auto failure = parse_steps(rest, m.points_)) return std::move(*failure);
    m.kind_ = Kind::steps;
  } else if (kind == "ramp") {
    const auto f = split(rest, ':');
    if (colon == std::string_view::npos || f.size() != 2)
      return fail(MotionError::wrong_field_count, "ramp: expected ramp:<turns_per_s>:<max_turns>");
    if (auto msg = number(f[0], "ramp: turns_per_s", m.a_); !msg.empty()) return fail(MotionError::bad_number, msg);
    if (auto msg = number(f[1], "ramp: max_turns", m.b_); !msg.empty()) return fail(MotionError::bad_number, msg);
    if (!(m.a_ > 0.0)) return fail(MotionError::bad_ramp, "ramp: turns_per_s '" + std::string(f[0]) + "' must be > 0");
    if (m.b_ == 0.0) return fail(MotionError::bad_ramp, "ramp: max_turns '" + std::string(f[1]) + "' must not be 0");
    m.kind_ = Kind::ramp;
  } else if (kind == "script") {
    if (auto failure = parse_script(rest, m.points_)) return std::move(*failure);
    m.kind_ = Kind::script;
  } else {
    return fail(MotionError::unknown_kind,
                "unknown motion kind '" + std::string(kind) + "' (constant, sine, steps, ramp, script)");
  }
  MotionParseResult r;
  r.motion = std::move(m);
  return r;
}

double Motion::curve_at(double t) const noexcept {
  switch (kind_) {
    case Kind::constant: return a_ * t;
    case Kind::sine: return c_ + a_ * std::sin(2.0 * std::numbers::pi * t / b_);
    case Kind::steps: return piecewise(points_, t, false);
    case Kind::script: return piecewise(points_, t, true);
    case Kind::ramp: {
      // Triangle wave of period 2|max|/v starting at 0, reaching max at half period.
      const double span = std::fabs(b_);
      const double period = 2.0 * span / a_;
      double phase = std::fmod(t, period);
      if (phase < 0.0) phase += period;
      const double up = phase * a_;
      const double magnitude = up <= span ? up : 2.0 * span - up;
      return b_ < 0.0 ? -magnitude : magnitude;
    }
  }
  return 0.0;
}

double Motion::turns_at(double seconds) const noexcept { return curve_at(seconds) + offset_; }

}  // namespace cobridge::sim
