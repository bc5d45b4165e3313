// btflod-convert — inspect, synthesise and convert BTF material files.
//
//   btflod-convert                      list the commands
//   btflod-convert COMMAND --help       help of one command
//   btflod-convert COMMAND ARGS...      run it (exit 0 ok, 1 failure, 2 usage error)
//
// Commands register themselves (command.hpp); this file never changes when one is added.
#include <cstdio>
#include <string_view>

#include "command.hpp"

namespace {

int print_usage(std::FILE* out) {
  std::fprintf(out,
               "usage: btflod-convert COMMAND [ARGS...]   (btflod-convert COMMAND --help for details)\n\ncommands:\n");
  for (const auto& c : btflod::convert::sorted_commands()) std::fprintf(out, "  %-12s %s\n", c.name, c.help);
  return out == stdout ? btflod::convert::kExitOk : btflod::convert::kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return print_usage(stderr);
  const std::string_view name = argv[1];
  if (name == "--help" || name == "-h" || name == "help") {
    if (name == "help" && argc >= 3) {
      if (const auto* c = btflod::convert::find_command(argv[2])) {
        std::puts(c->usage);
        return btflod::convert::kExitOk;
      }
    }
    return print_usage(stdout);
  }
  const auto* command = btflod::convert::find_command(name);
  if (!command) {
    std::fprintf(stderr, "btflod-convert: unknown command '%s'\n\n", argv[1]);
    return print_usage(stderr);
  }
  return btflod::convert::run_command(*command, argc - 1, argv + 1);
}
