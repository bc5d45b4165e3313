// btflod-demo — the main job. For now (issue 2): synthesise a small BTF, write it, read it
// back, print a summary and write a PNG contact sheet plus a bounded number of headless
// frames. Each step lives in demo_steps.hpp; later issues add factorisation, the tile
// pyramid, streaming and rendering as further steps here.
#include <cstdio>
#include <filesystem>

#include "command_line.hpp"
#include "demo_steps.hpp"

int main(int argc, char** argv) {
  using namespace btflod;
  int exit_code = 0;
  const auto cfg = demo::parse_command_line(argc, argv, &exit_code);
  if (!cfg) return exit_code;
  std::error_code ec;
  std::filesystem::create_directories(cfg->out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "btflod-demo: %s: cannot create: %s\n", cfg->out_dir.c_str(), ec.message().c_str());
    return 1;
  }
  auto fail = [](const char* step, const std::string& message) {
    std::fprintf(stderr, "btflod-demo: %s: %s\n", step, message.c_str());
    return 1;
  };

  const demo::Stopwatch synth_clock;
  auto btf = demo::synthesize_material(*cfg);
  if (!btf) return fail("synthesis", btf.message());
  const double synth_seconds = synth_clock.seconds();

  auto read_back = demo::write_and_read_back(*cfg, *btf);
  if (!read_back) return fail("write/read back", read_back.message());
  const BtfFloat& shown = read_back->done ? read_back->btf : *btf;

  demo::print_summary(*cfg, *btf, synth_seconds, *read_back);

  auto sheet = demo::write_contact_sheet(*cfg, shown);
  if (!sheet) return fail("contact sheet", sheet.message());
  std::printf("  contact     %s\n", sheet->c_str());

  auto frames = demo::write_frames(*cfg, shown);
  if (!frames) return fail("frames", frames.message());
  std::printf("  frames      %d PNG frames in %s/frames\n", *frames, cfg->out_dir.c_str());

  // The read-back must reproduce the material: a broken writer/reader pair fails the demo
  // (and its ctest). Truncating to K components loses little on these smooth materials.
  if (read_back->done && !(read_back->relative < 0.25)) {
    std::fprintf(stderr, "btflod-demo: read-back relative RMSE %.3g is too large\n", read_back->relative);
    return 1;
  }
  return 0;
}
