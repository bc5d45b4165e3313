// btflod-bench — timing helpers, statistics over repetitions, and the JSON report.
//
// Report schema (format "btflod-bench-report", version 1; stable: fields are only ever added):
//   { "format": "btflod-bench-report", "version": 1, "kind": "scheduler" | "codec",
//     "inputs": { <string or number fields describing what was measured> },
//     "metrics": [ { "name": "...", "value": <median over repetitions>, "unit": "...",
//                    "better": "lower" | "higher" | "none", "noise": <relative spread>,
//                    "repetitions": N }, ... ] }
// "noise" is (max − min) / median of the metric over the repetitions of the run: the band within
// which `btflod-bench compare` treats a change as noise. Counters of a deterministic replay have
// noise 0 and better "none" (a change there is a behaviour change, reported but not a regression).
#pragma once

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "btflod/core/result.hpp"

namespace btflod::bench {

/// CPU time of the calling thread in nanoseconds: the machine may be shared, so wall time would
/// charge other processes to the code being measured.
inline double thread_cpu_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

/// The q-quantile (0 … 1) of values by linear interpolation between order statistics.
/// Returns 0 for an empty list. Sorts a copy.
inline double percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double pos = q * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (values[hi] - values[lo]) * (pos - static_cast<double>(lo));
}

enum class Better { lower, higher, none };

inline const char* better_name(Better b) {
  return b == Better::lower ? "lower" : b == Better::higher ? "higher" : "none";
}

/// One reported figure: the median of its repetitions and their relative spread.
struct Metric {
  std::string name;
  std::string unit;
  Better better = Better::none;
  std::vector<double> samples;  ///< one per repetition
  double value = 0;             ///< median of samples (or as read from a report)
  double noise = 0;             ///< (max − min) / median
  int repetitions = 0;
  void finish() {
    repetitions = static_cast<int>(samples.size());
    value = percentile(samples, 0.5);
    if (samples.empty() || value == 0.0) {
      noise = 0.0;
      return;
    }
    const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
    noise = (*hi - *lo) / std::fabs(value);
  }
};

/// A set of metrics in insertion order, plus the inputs that describe the run.
class Report {
 public:
  explicit Report(std::string kind) : kind_(std::move(kind)) {}
  /// Adds one repetition's value of a metric (created on first use).
  void add(const std::string& name, double v, const char* unit, Better better) {
    auto it = index_.find(name);
    if (it == index_.end()) {
      index_[name] = metrics_.size();
      metrics_.push_back(Metric{name, unit, better, {}, 0, 0, 0});
      it = index_.find(name);
    }
    metrics_[it->second].samples.push_back(v);
  }
  void input(const std::string& key, const std::string& value) {
    inputs_.emplace_back(key, "\"" + escape(value) + "\"");
  }
  void input(const std::string& key, double value) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", value);
    inputs_.emplace_back(key, buf);
  }
  void finish() {
    for (Metric& m : metrics_) m.finish();
  }
  const Metric* find(const std::string& name) const {
    auto it = index_.find(name);
    return it == index_.end() ? nullptr : &metrics_[it->second];
  }
  const std::vector<Metric>& metrics() const { return metrics_; }

  /// The report as JSON text (schema in the file comment).
  std::string json() const {
    std::string s = "{\n  \"format\": \"btflod-bench-report\",\n  \"version\": 1,\n  \"kind\": \"" + kind_ + "\",\n";
    s += "  \"inputs\": {";
    for (size_t i = 0; i < inputs_.size(); ++i)
      s += (i ? ", " : "") + std::string("\"") + escape(inputs_[i].first) + "\": " + inputs_[i].second;
    s += "},\n  \"metrics\": [\n";
    for (size_t i = 0; i < metrics_.size(); ++i) {
      const Metric& m = metrics_[i];
      char buf[512];
      std::snprintf(buf, sizeof buf,
                    "    {\"name\": \"%s\", \"value\": %.9g, \"unit\": \"%s\", \"better\": \"%s\", \"noise\": %.6g, "
                    "\"repetitions\": %d}%s\n",
                    escape(m.name).c_str(), m.value, escape(m.unit).c_str(), better_name(m.better), m.noise,
                    m.repetitions, i + 1 < metrics_.size() ? "," : "");
      s += buf;
    }
    s += "  ]\n}\n";
    return s;
  }

  static std::string escape(const std::string& in) {
    std::string out;
    for (char c : in) {
      if (c == '"' || c == '\\') out += '\\';
      if (static_cast<unsigned char>(c) < 0x20) {
        out += ' ';
        continue;
      }
      out += c;
    }
    return out;
  }

 private:
  std::string kind_;
  std::vector<std::pair<std::string, std::string>> inputs_;
  std::vector<Metric> metrics_;
  std::map<std::string, size_t> index_;
};

/// Writes text to a file; io_error with the path on failure.
inline VoidResult write_text(const std::string& path, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return make_error(Status::io_error, "%s: cannot create", path.c_str());
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) return make_error(Status::io_error, "%s: short write", path.c_str());
  return {};
}

// --- reading reports back (compare) ------------------------------------------------------------
// A small JSON reader for the report schema: objects, arrays, strings (simple escapes), numbers,
// true/false/null. Anything else is an error with the byte offset.
struct JsonValue {
  enum class Type { null, boolean, number, string, array, object } type = Type::null;
  double number = 0;
  bool boolean = false;
  std::string string;
  std::vector<JsonValue> items;
  std::vector<std::pair<std::string, JsonValue>> fields;
  const JsonValue* get(const std::string& key) const {
    for (const auto& [k, v] : fields)
      if (k == key) return &v;
    return nullptr;
  }
};

class JsonParser {
 public:
  explicit JsonParser(const std::string& text) : s_(text) {}
  Result<JsonValue> parse() {
    JsonValue v;
    if (!value(v, 0)) return make_error(Status::bad_data, "JSON: %s at byte %zu", why_.c_str(), pos_);
    ws();
    if (pos_ != s_.size()) return make_error(Status::bad_data, "JSON: trailing characters at byte %zu", pos_);
    return v;
  }

 private:
  void ws() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  bool fail(const char* w) {
    why_ = w;
    return false;
  }
  bool str(std::string& out) {
    if (pos_ >= s_.size() || s_[pos_] != '"') return fail("expected a string");
    ++pos_;
    while (pos_ < s_.size() && s_[pos_] != '"') {
      if (s_[pos_] == '\\') {
        if (++pos_ >= s_.size()) return fail("unterminated escape");
        const char e = s_[pos_];
        out += e == 'n' ? '\n' : e == 't' ? '\t' : e;
      } else {
        out += s_[pos_];
      }
      ++pos_;
    }
    if (pos_ >= s_.size()) return fail("unterminated string");
    ++pos_;
    return true;
  }
  // The rest of an object or array after its opening bracket: `item()` parses one member or
  // element (false on error), members are separated by ',' and `close` ends the list;
  // `expected` is the error after a member that is followed by neither.
  template <class Item>
  bool items(char close, const char* expected, Item&& item) {
    ws();
    if (pos_ < s_.size() && s_[pos_] == close) return ++pos_, true;
    for (;;) {
      if (!item()) return false;
      ws();
      if (pos_ < s_.size() && s_[pos_] == ',') {
        ++pos_;
        continue;
      }
      if (pos_ < s_.size() && s_[pos_] == close) return ++pos_, true;
      return fail(expected);
    }
  }
  bool value(JsonValue& v, int depth) {
    if (depth > 32) return fail("nesting too deep");
    ws();
    if (pos_ >= s_.size()) return fail("unexpected end");
    const char c = s_[pos_];
    if (c == '{') {
      v.type = JsonValue::Type::object;
      ++pos_;
      return items('}', "expected ',' or '}'", [&] {
        ws();
        std::string key;
        if (!str(key)) return false;
        ws();
        if (pos_ >= s_.size() || s_[pos_] != ':') return fail("expected ':'");
        ++pos_;
        JsonValue item;
        if (!value(item, depth + 1)) return false;
        v.fields.emplace_back(std::move(key), std::move(item));
        return true;
      });
    }
    if (c == '[') {
      v.type = JsonValue::Type::array;
      ++pos_;
      return items(']', "expected ',' or ']'", [&] {
        JsonValue item;
        if (!value(item, depth + 1)) return false;
        v.items.push_back(std::move(item));
        return true;
      });
    }
    if (c == '"') {
      v.type = JsonValue::Type::string;
      return str(v.string);
    }
    for (const char* lit : {"true", "false", "null"}) {
      const size_t n = std::char_traits<char>::length(lit);
      if (s_.compare(pos_, n, lit) == 0) {
        pos_ += n;
        v.type = lit[0] == 'n' ? JsonValue::Type::null : JsonValue::Type::boolean;
        v.boolean = lit[0] == 't';
        return true;
      }
    }
    const char* begin = s_.c_str() + pos_;
    char* end = nullptr;
    v.number = std::strtod(begin, &end);
    if (end == begin) return fail("unexpected character");
    v.type = JsonValue::Type::number;
    pos_ += static_cast<size_t>(end - begin);
    return true;
  }
  const std::string& s_;
  size_t pos_ = 0;
  std::string why_;
};

/// Reads a report written by Report::json(): its kind and metrics (value, noise, better, unit).
inline Result<std::pair<std::string, std::vector<Metric>>> read_report(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return make_error(Status::io_error, "%s: cannot open", path.c_str());
  std::string text;
  char buf[4096];
  size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
  std::fclose(f);
  auto root = JsonParser(text).parse();
  if (!root) return make_error(Status::bad_data, "%s: %s", path.c_str(), root.message().c_str());
  const JsonValue* format = root->get("format");
  const JsonValue* kind = root->get("kind");
  const JsonValue* metrics = root->get("metrics");
  if (!format || format->string != "btflod-bench-report" || !kind || !metrics ||
      metrics->type != JsonValue::Type::array)
    return make_error(Status::bad_data, "%s: not a btflod-bench report (format, kind, metrics)", path.c_str());
  std::vector<Metric> out;
  for (const JsonValue& m : metrics->items) {
    const JsonValue* name = m.get("name");
    const JsonValue* value = m.get("value");
    if (!name || !value || value->type != JsonValue::Type::number)
      return make_error(Status::bad_data, "%s: a metric without name or numeric value", path.c_str());
    Metric x;
    x.name = name->string;
    x.value = value->number;
    if (const JsonValue* v = m.get("noise")) x.noise = v->number;
    if (const JsonValue* v = m.get("unit")) x.unit = v->string;
    if (const JsonValue* v = m.get("repetitions")) x.repetitions = static_cast<int>(v->number);
    if (const JsonValue* v = m.get("better"))
      x.better = v->string == "lower" ? Better::lower : v->string == "higher" ? Better::higher : Better::none;
    out.push_back(std::move(x));
  }
  return std::make_pair(kind->string, std::move(out));
}

}  // namespace btflod::bench
