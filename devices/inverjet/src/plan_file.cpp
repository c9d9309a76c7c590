#include "rtukit/devices/inverjet/plan_file.hpp"

#include <fmt/core.h>

#include <charconv>
#include <nlohmann/json.hpp>

#include "rtukit/devices/inverjet/client.hpp"
#include "rtukit/devices/profile/text.hpp"
#include "rtukit/io/atomic_file.hpp"

namespace rtukit::inverjet {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// One segment from its two fields; `where` prefixes errors ("line 3", "entry 2").
bool make_segment(std::string_view speed_text, std::string_view end_text, const std::string& where,
                  Segment* out, std::string* why) {
  unsigned speed = 0;
  const auto [p, ec] = std::from_chars(speed_text.data(), speed_text.data() + speed_text.size(), speed);
  if (speed_text.empty() || ec != std::errc{} || p != speed_text.data() + speed_text.size()) {
    *why = fmt::format("{}: speed '{}' is not a number", where, speed_text);
    return false;
  }
  if (speed > kMaxSpeed) {
    *why = fmt::format("{}: speed {} % is out of range 0..100", where, speed);
    return false;
  }
  const Result<uint32_t> end = profile::parse_duration(end_text);
  if (!end.ok()) {
    *why = fmt::format("{}: end time '{}': {}", where, end_text, end.error().reason());
    return false;
  }
  if (*end > kMaxTime) {
    *why = fmt::format("{}: end time {} is out of range (at most 99:59)", where, end_text);
    return false;
  }
  *out = Segment{static_cast<uint16_t>(speed), static_cast<uint16_t>(*end)};
  return true;
}

// Order: 1..50 segments, end times increasing. Names the line of the culprit.
bool check_order(const std::vector<Segment>& segments, const std::vector<std::string>& where,
                 std::string* why) {
  if (segments.empty()) {
    *why = "the plan has no segments";
    return false;
  }
  if (segments.size() > kSegmentsPerPlan) {
    *why =
        fmt::format("{}: segment {}; a plan holds at most 50", where[kSegmentsPerPlan], kSegmentsPerPlan + 1);
    return false;
  }
  uint16_t previous = 0;
  for (size_t i = 0; i < segments.size(); ++i) {
    if (segments[i].end <= previous) {
      *why = fmt::format("{}: end {} is not after {} (end times must increase)", where[i],
                         profile::format_mm_ss(segments[i].end), profile::format_mm_ss(previous));
      return false;
    }
    previous = segments[i].end;
  }
  return true;
}

}  // namespace

Outcome<std::vector<Segment>> parse_plan(std::string_view text) {
  std::string reason;
  std::vector<Segment> segments;
  std::vector<std::string> where;
  const std::string_view body = trim(text);
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string_view::npos && (text[first] == '[' || text[first] == '{')) {
    nlohmann::json j = nlohmann::json::parse(body, nullptr, false);
    // `plan show --json` prints a document with the segments in it; it reads back too.
    if (j.is_object() && j.contains("segments")) j = nlohmann::json(j["segments"]);
    if (j.is_discarded() || !j.is_array()) {
      reason =
          "not a valid JSON array of {\"speed\": .., \"end\": \"mm:ss\"} (or a document with \"segments\")";
    } else {
      for (size_t i = 0; i < j.size() && reason.empty(); ++i) {
        const std::string at = fmt::format("entry {}", i + 1);
        const auto& e = j[i];
        if (!e.is_object() || !e.contains("speed") || !e.contains("end")) {
          reason = at + ": needs \"speed\" and \"end\"";
          break;
        }
        const auto field = [](const nlohmann::json& v) {
          return v.is_string()            ? v.get<std::string>()
                 : v.is_number_unsigned() ? std::to_string(v.get<uint64_t>())
                                          : v.dump();
        };
        Segment s;
        if (!make_segment(field(e["speed"]), field(e["end"]), at, &s, &reason)) break;
        segments.push_back(s);
        where.push_back(at);
      }
    }
  } else {
    size_t line_no = 0;
    size_t pos = 0;
    while (pos <= text.size() && reason.empty()) {
      const size_t nl = text.find('\n', pos);
      const std::string_view line =
          trim(text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos));
      pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
      ++line_no;
      if (line.empty() || line.front() == '#') continue;
      const std::string at = fmt::format("line {}", line_no);
      const size_t comma = line.find(',');
      if (comma == std::string_view::npos || line.find(',', comma + 1) != std::string_view::npos) {
        reason = at + ": expected 'speed,end' (two fields)";
        break;
      }
      const std::string_view a = trim(line.substr(0, comma));
      const std::string_view b = trim(line.substr(comma + 1));
      if (segments.empty() && where.empty() && a == "speed" && b == "end") continue;  // header
      Segment s;
      if (!make_segment(a, b, at, &s, &reason)) break;
      segments.push_back(s);
      where.push_back(at);
    }
  }
  if (reason.empty()) check_order(segments, where, &reason);
  if (!reason.empty()) return rtukit::Status(Errc::invalid_argument, reason);
  return segments;
}

std::string plan_to_csv(const std::vector<Segment>& segments) {
  std::string out = "speed,end\n";
  for (const Segment& s : segments) out += fmt::format("{},{}\n", s.speed, profile::format_mm_ss(s.end));
  return out;
}

nlohmann::ordered_json plan_json(const std::vector<Segment>& segments) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const Segment& seg : segments) {
    nlohmann::ordered_json entry;
    entry["speed"] = seg.speed;
    entry["end"] = profile::format_mm_ss(seg.end);
    entry["end_s"] = seg.end;
    list.push_back(std::move(entry));
  }
  return list;
}

Outcome<std::vector<Segment>> read_plan_file(const std::string& path) {
  const Outcome<std::string> text = io::read_regular_file(path, 64 * 1024);
  // As a map file (map_file.cpp): a file the OS cannot give is an I/O error
  // (the CLI's exit 4, as `map check`; it was 2), one that is no plan file
  // (not a regular file, too large) a usage error.
  if (!text.ok()) {
    const rtukit::Status& e = text.error();
    if (e.code() == Errc::io_error)  // the OS's words follow from the error (the CLI's "I/O error: ...")
      return rtukit::Status(e.error(), fmt::format("cannot read plan file '{}'", path));
    return rtukit::Status(Errc::invalid_argument,
                          fmt::format("cannot read plan file '{}': {}", path, e.reason()));
  }
  Outcome<std::vector<Segment>> segments = parse_plan(*text);
  if (!segments.ok())
    return rtukit::Status(Errc::invalid_argument, fmt::format("{}: {}", path, segments.error().reason()));
  return segments;
}

}  // namespace rtukit::inverjet
