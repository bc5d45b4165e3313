// btflod-convert — the subcommand registry and its commands' option parser.
//
// Adding a command needs no edit to any existing file: create samples/tools/convert/cmd_<name>.cpp
// (the CMakeLists.txt globs cmd_*.cpp; `// btflod-link:` lines at the top add libraries, see
// cmake/BtflodTargetDirectives.cmake) containing
//
//   #include "command.hpp"
//   namespace {
//   constexpr char kUsage[] = "usage: btflod-convert frobnicate FILE [--level N]";
//   int run_frobnicate(btflod::convert::Options& opt) {  // --help was handled by the dispatcher
//     auto level = opt.integer("level", 3, 0, 9);         // --level N or --level=N
//     ...
//     if (!opt.finish()) return 2;                        // unknown options / bad values → usage error
//     ...
//     return 0;                                           // 0 ok, 1 failure, 2 usage error
//   }
//   }  // namespace
//   BTFLOD_CONVERT_COMMAND(frobnicate, "one line of help", kUsage, run_frobnicate);
//
// Commands are listed sorted by name by `btflod-convert --help`.
#pragma once

#include <algorithm>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "common/arguments.hpp"

namespace btflod::convert {

/// Exit codes shared by all commands.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

class Options;

/// A command's body: called with its parsed command line once -h / --help has been ruled out.
using CommandFunction = int (*)(Options& opt);

struct Command {
  const char* name;
  const char* help;   ///< one line, for the command list
  const char* usage;  ///< the full text printed by `btflod-convert NAME --help`
  CommandFunction run;
};

/// All registered commands (function-local static: safe against static initialisation order).
inline std::vector<Command>& command_registry() {
  static std::vector<Command> commands;
  return commands;
}

/// Registers a command at static-initialisation time (use BTFLOD_CONVERT_COMMAND).
struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* help, const char* usage, CommandFunction run) {
    command_registry().push_back({name, help, usage, run});
  }
};

/// Finds a command by name; null when none has that name.
inline const Command* find_command(std::string_view name) {
  for (const auto& c : command_registry())
    if (name == c.name) return &c;
  return nullptr;
}

/// Commands sorted by name.
inline std::vector<Command> sorted_commands() {
  auto v = command_registry();
  std::sort(v.begin(), v.end(), [](const Command& a, const Command& b) { return std::string_view(a.name) < b.name; });
  return v;
}

#define BTFLOD_CONVERT_COMMAND(name, help, usage, function) \
  static const ::btflod::convert::CommandRegistrar btflod_convert_command_##name { #name, help, usage, function }

/// A command's options: the samples' parser (common/arguments.hpp), its messages prefixed with
/// "btflod-convert <command>".
class Options : public samples::Arguments {
 public:
  /// argv[0] is the command name and is skipped.
  Options(int argc, char** argv)
      : samples::Arguments(std::string("btflod-convert ") + (argc > 0 ? argv[0] : ""), argc, argv),
        argc_(argc),
        argv_(argv) {}

  /// The command line as given (argv[0] is the command name), for libraries that read it
  /// themselves (MPI_Init).
  int& argc() noexcept { return argc_; }
  char**& argv() noexcept { return argv_; }

 private:
  int argc_;
  char** argv_;
};

/// Reads --profile: true for `--profile paper` (the sizes of the papers' experiments), false
/// when it is absent; any other value is reported as a usage error, so opt.finish() fails.
inline bool paper_profile(Options& opt) {
  const std::string profile = opt.string("profile", "");
  if (!profile.empty() && profile != "paper") opt.error("--profile " + profile + ": expected paper");
  return profile == "paper";
}

/// Runs `command` on its command line (argv[0] is the command name): prints its usage and
/// returns kExitOk when -h / --help is present, otherwise returns what the command returns.
inline int run_command(const Command& command, int argc, char** argv) {
  Options opt(argc, argv);
  if (opt.wants_help()) {
    std::puts(command.usage);
    return kExitOk;
  }
  return command.run(opt);
}

}  // namespace btflod::convert
