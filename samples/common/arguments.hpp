// The samples' one command-line parser: every program and btflod-convert's commands read their
// options through it, so `--name value`, `--name=value`, `-n value`, flags, ranges and error
// messages behave alike everywhere.
//
//   btflod::samples::Arguments args("btflod-replay", argc, argv);   // argv[0] is skipped
//   if (args.wants_help()) { std::puts(kUsage); return 0; }
//   o.frames = args.integer_as("frames", o.frames, 1, 1000000);     // --frames N, --frames=N
//   o.quiet = args.flag("quiet", 'q');
//   if (!args.finish(0)) return 2;                                  // unknown options, bad values
//
// Query every option the program knows, then call finish(): anything left that starts with '-'
// is an unknown option, the other words are the positional arguments. Each problem is printed
// once on stderr as "<program>: <problem>"; a bad value leaves the fallback in place.
#pragma once

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace btflod::samples {

class Arguments {
 public:
  /// `program` prefixes every message; argv[0] (the program or command name) is skipped.
  Arguments(std::string program, int argc, char** argv) : program_(std::move(program)) {
    for (int i = 1; i < argc; ++i) tokens_.push_back({argv[i], false});
  }

  /// The prefix of this parser's messages.
  const std::string& program() const noexcept { return program_; }

  /// True for -h / --help (and consumes it).
  bool wants_help() { return flag("help", 'h'); }

  /// True when --name (or -s) is present; consumes every occurrence.
  bool flag(std::string_view name, char short_name = 0) {
    bool found = false;
    for (auto& t : tokens_) {
      if (t.used) continue;
      if (is_long(t.text, name) || is_short(t.text, short_name)) {
        t.used = true;
        found = true;
      }
    }
    return found;
  }

  /// Every value of --name V / --name=V / -s V, in order (a repeatable option: --bsvtf A
  /// --bsvtf B). A missing value after the option is an error.
  std::vector<std::string> values(std::string_view name, char short_name = 0) {
    std::vector<std::string> out;
    for (size_t i = 0; i < tokens_.size(); ++i) {
      auto& t = tokens_[i];
      if (t.used) continue;
      const std::string& s = t.text;
      if (s.size() > name.size() + 2 && s.compare(0, 2, "--") == 0 && s.compare(2, name.size(), name) == 0 &&
          s[2 + name.size()] == '=') {
        t.used = true;
        out.push_back(s.substr(3 + name.size()));
      } else if (is_long(s, name) || is_short(s, short_name)) {
        t.used = true;
        if (i + 1 < tokens_.size() && !tokens_[i + 1].used) {
          tokens_[i + 1].used = true;
          out.push_back(tokens_[i + 1].text);
          ++i;
        } else {
          error("option " + s + " needs a value");
        }
      }
    }
    return out;
  }

  /// The value of --name V / --name=V / -s V (the last one wins), or nullopt when absent.
  std::optional<std::string> value(std::string_view name, char short_name = 0) {
    std::vector<std::string> all = values(name, short_name);
    if (all.empty()) return std::nullopt;
    return std::move(all.back());
  }

  /// The value of --name, or `fallback` when absent.
  std::string string(std::string_view name, std::string fallback, char short_name = 0) {
    auto v = value(name, short_name);
    return v ? *v : std::move(fallback);
  }

  /// An integer in [lo, hi], or nullopt when absent or bad (a bad value is an error).
  std::optional<long long> optional_integer(std::string_view name, long long lo, long long hi, char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return std::nullopt;
    errno = 0;
    char* end = nullptr;
    const long long x = std::strtoll(v->c_str(), &end, 10);
    if (errno != 0 || end == v->c_str() || *end != '\0' || x < lo || x > hi) {
      error("--" + std::string(name) + " " + *v + ": expected an integer in [" + std::to_string(lo) + ", " +
            std::to_string(hi) + "]");
      return std::nullopt;
    }
    return x;
  }

  /// An integer in [lo, hi]; `fallback` when absent or bad.
  long long integer(std::string_view name, long long fallback, long long lo, long long hi, char short_name = 0) {
    return optional_integer(name, lo, hi, short_name).value_or(fallback);
  }

  /// The same, converted to T (an integer type holding [lo, hi]).
  template <typename T>
  T integer_as(std::string_view name, T fallback, long long lo, long long hi, char short_name = 0) {
    return static_cast<T>(integer(name, static_cast<long long>(fallback), lo, hi, short_name));
  }

  /// A non-negative 64-bit integer (decimal, or 0x… hex: seeds); `fallback` when absent or bad.
  unsigned long long unsigned_integer(std::string_view name, unsigned long long fallback, char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return fallback;
    errno = 0;
    char* end = nullptr;
    const unsigned long long x = std::strtoull(v->c_str(), &end, 0);
    if (errno != 0 || end == v->c_str() || *end != '\0' || (*v)[0] == '-') {
      error("--" + std::string(name) + " " + *v + ": expected a non-negative integer");
      return fallback;
    }
    return x;
  }

  /// A number in [lo, hi], or nullopt when absent or bad.
  std::optional<double> optional_number(std::string_view name, double lo, double hi, char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return std::nullopt;
    char* end = nullptr;
    const double x = std::strtod(v->c_str(), &end);
    if (end == v->c_str() || *end != '\0' || !(x >= lo && x <= hi)) {
      error("--" + std::string(name) + " " + *v + ": expected a number in [" + shortest(lo) + ", " + shortest(hi) +
            "]");
      return std::nullopt;
    }
    return x;
  }

  /// A number in [lo, hi]; `fallback` when absent or bad.
  double number(std::string_view name, double fallback, double lo, double hi, char short_name = 0) {
    return optional_number(name, lo, hi, short_name).value_or(fallback);
  }

  /// A byte count with an optional K, M or G suffix (powers of 1024), in (0, 10^15]; nullopt when
  /// absent or bad.
  std::optional<uint64_t> byte_size(std::string_view name) {
    auto v = value(name);
    if (!v) return std::nullopt;
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(v->c_str(), &end);
    const std::string_view unit = end ? std::string_view(end) : std::string_view();
    const double scale = unit.empty()  ? 1.0
                         : unit == "K" ? 1024.0
                         : unit == "M" ? 1048576.0
                         : unit == "G" ? 1073741824.0
                                       : 0.0;
    if (errno != 0 || end == v->c_str() || !(x > 0.0) || scale == 0.0 || x * scale > 1e15) {
      error("--" + std::string(name) + " " + *v + ": expected a size such as 512M or 4G");
      return std::nullopt;
    }
    return static_cast<uint64_t>(x * scale);
  }

  /// The comma-separated items of --name (none empty), or nullopt when absent or bad.
  std::optional<std::vector<std::string>> list(std::string_view name) {
    auto v = value(name);
    if (!v) return std::nullopt;
    std::vector<std::string> items(1);
    for (char c : *v) {
      if (c == ',')
        items.emplace_back();
      else
        items.back() += c;
    }
    for (const std::string& item : items) {
      if (item.empty()) {
        error("--" + std::string(name) + " " + *v + ": expected a comma-separated list without empty items");
        return std::nullopt;
      }
    }
    return items;
  }

  /// Which of `names` --name gives (its index), or nullopt when absent or not one of them.
  std::optional<size_t> choice(std::string_view name, std::initializer_list<std::string_view> names,
                               char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return std::nullopt;
    size_t i = 0;
    for (std::string_view n : names) {
      if (*v == n) return i;
      ++i;
    }
    std::string list;
    i = 0;
    for (std::string_view n : names) {
      list += i == 0 ? "" : i + 1 == names.size() ? " or " : ", ";
      list += n;
      ++i;
    }
    error("--" + std::string(name) + " " + *v + ": expected " + list);
    return std::nullopt;
  }

  /// Records a usage error (printed by finish()).
  void error(std::string message) { errors_.push_back(std::move(message)); }

  /// Collects the positional arguments, reports unknown options, more than `max_positional`
  /// positional arguments and the recorded errors on stderr. Returns false when there was any
  /// problem (the program should exit with status 2).
  bool finish(size_t max_positional = std::numeric_limits<size_t>::max()) {
    positional_.clear();
    for (auto& t : tokens_) {
      if (t.used) continue;
      if (t.text.size() > 1 && t.text[0] == '-') {
        errors_.push_back("unknown option " + t.text);
      } else if (positional_.size() < max_positional) {
        positional_.push_back(t.text);
      } else {
        errors_.push_back("unexpected argument " + t.text);
      }
      t.used = true;
    }
    for (const auto& e : errors_) std::fprintf(stderr, "%s: %s\n", program_.c_str(), e.c_str());
    return errors_.empty();
  }

  /// Positional arguments, in order (valid after finish()).
  const std::vector<std::string>& positional() const noexcept { return positional_; }

 private:
  struct Token {
    std::string text;
    bool used;
  };
  static bool is_long(const std::string& s, std::string_view name) {
    return s.size() == name.size() + 2 && s.compare(0, 2, "--") == 0 && s.compare(2, std::string::npos, name) == 0;
  }
  static bool is_short(const std::string& s, char c) { return c != 0 && s.size() == 2 && s[0] == '-' && s[1] == c; }
  static std::string shortest(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return buf;
  }

  std::string program_;
  std::vector<Token> tokens_;
  std::vector<std::string> positional_;
  std::vector<std::string> errors_;
};

}  // namespace btflod::samples
