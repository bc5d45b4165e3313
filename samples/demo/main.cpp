// btflod-demo — the main job: synthesise a few procedural BTFs, factorise them (FMF), build
// .bsvtf containers, then fly a camera through a scene of BTF-textured tori on a plane while
// streaming tiles through a throttled source and the streaming pipeline, rendering BSVTF with
// the GL backend (FMF of the same view is the converged reference). Writes frames, a contact
// sheet, report.html and report.json. The phases live in materials.hpp, stream_render.hpp,
// report.hpp and samples/scene/demo_scene.hpp; this file only calls them in order.
#include <cstdio>
#include <filesystem>
#include <string>

#include "command_line.hpp"
#include "demo_steps.hpp"
#if BTFLOD_DEMO_HAS_GL
#include "gl_backend.hpp"
#endif
#include "materials.hpp"
#include "report.hpp"
#include "stream_render.hpp"

int main(int argc, char** argv) {
  using namespace btflod;
  int exit_code = 0;
  const auto cfg = demo::parse_command_line(argc, argv, &exit_code);
  if (!cfg) return exit_code;
  const std::filesystem::path out(cfg->out_dir);
  std::error_code ec;
  std::filesystem::create_directories(out / "frames", ec);
  if (ec) {
    std::fprintf(stderr, "btflod-demo: %s: cannot create: %s\n", cfg->out_dir.c_str(), ec.message().c_str());
    return 1;
  }
  auto fail = [](const char* step, const std::string& message) {
    std::fprintf(stderr, "btflod-demo: %s: %s\n", step, message.c_str());
    return 1;
  };

  // 1. Backend first, so a missing GPU API is reported before the slow steps.
  if (cfg->backend == "cpu")
    return fail("backend", "the CPU reference backend is not wired into the demo yet (use --backend gl)");
#if BTFLOD_DEMO_HAS_GL
  auto backend = samples::create_gl_backend();
#else
  Result<std::unique_ptr<Backend>> backend = make_error(Status::unsupported, "built without btflod_gl_backend");
#endif
  if (!backend)
    return fail("backend", "no OpenGL 4.5 (EGL) available: " + backend.message() +
                               "; a CPU fallback for the demo is not implemented yet");
  std::printf("btflod demo: backend %s\n", (*backend)->name());

  // 2. Materials: synthesise, factorise (FMF), build .bsvtf.
  const demo::Stopwatch prep_clock;
  demo::MaterialSettings ms;
  ms.size = cfg->size;
  ms.seed = cfg->seed;
  std::vector<demo::DemoMaterial> materials;
  for (int i = 0; i < cfg->materials; ++i) {
    auto m = demo::prepare_material(static_cast<uint32_t>(i), ms, cfg->out_dir);
    if (!m) return fail("material", m.message());
    std::printf("  material    %s: %dx%d texels x %u views x %u lights, FMF C=%u (relative error %.3f), %s (%zu bytes)\n",
                m->name.c_str(), m->eigen_textures.width(), m->eigen_textures.height(), m->view_count, m->light_count,
                m->components, m->fmf_relative_error, m->bsvtf_path.c_str(), m->bsvtf.size());
    materials.push_back(std::move(*m));
  }
  const double prep_seconds = prep_clock.seconds();

  // 3. Fly-through with streaming.
  demo::StreamSettings ss;
  ss.bytes_per_second = cfg->bandwidth_kib * 1024.0;
  auto renderer = demo::StreamingRenderer::create(**backend, materials, ss, static_cast<uint32_t>(materials.size()));
  if (!renderer) return fail("streaming set-up", renderer.message());
  demo::RunSummary run;
  run.backend = (*backend)->name();
  for (int i = 0; i < argc; ++i) run.command += (i ? " " : "") + std::string(argv[i]);
  run.materials = static_cast<uint32_t>(materials.size());
  run.width = ss.width;
  run.height = ss.height;
  run.slots = (*renderer)->slot_count();
  run.tiles = (*renderer)->tile_count();
  run.payload_bytes = (*renderer)->total_payload_bytes();
  run.bytes_per_second = ss.bytes_per_second;
  run.seconds_prepare = prep_seconds;
  run.memory = (*renderer)->memory();
  for (const auto& m : materials) {
    run.material_names.push_back(m.name);
    run.fmf_errors.push_back(m.fmf_relative_error);
  }
  Image<float> bsvtf_img(static_cast<int>(ss.width), static_cast<int>(ss.height), 4);
  Image<float> fmf_img(static_cast<int>(ss.width), static_cast<int>(ss.height), 4);
  std::vector<Image<float>> sheet;
  const uint32_t frames = static_cast<uint32_t>(cfg->frames);
  const uint32_t sheet_every = std::max(1u, (frames + 11) / 12);
  const demo::Stopwatch flight_clock;
  for (uint32_t f = 0; f < frames; ++f) {
    auto rec = (*renderer)->frame(f, frames, bsvtf_img, fmf_img);
    if (!rec) return fail("frame", rec.message());
    run.frames.push_back(*rec);
    char name[64];
    std::snprintf(name, sizeof name, "frame_%04u.png", f);
    if (auto w = write_png_srgb((out / "frames" / name).string(), bsvtf_img.view()); !w) return fail("frame png", w.message());
    if (f % sheet_every == 0 || f + 1 == frames) sheet.push_back(bsvtf_img);
    if (!cfg->quiet && (f % 10 == 0 || f + 1 == frames))
      std::printf("  frame %4u  %7.1f KiB received  SSIM %.4f  cache %5.1f%%  BSVTF %6.2f ms  FMF %6.2f ms\n", f,
                  static_cast<double>(rec->bytes_received) / 1024.0, rec->ssim, 100.0 * rec->occupancy, rec->ms_bsvtf,
                  rec->ms_fmf);
  }
  run.seconds_flight = flight_clock.seconds();

  // 4. Outputs.
  if (auto w = demo::write_frame_sheet((out / "contact_sheet_frames.png").string(), sheet); !w) return fail("contact sheet", w.message());
  if (auto w = demo::write_report_json((out / "report.json").string(), run); !w) return fail("report.json", w.message());
  if (auto w = demo::write_report_html((out / "report.html").string(), run); !w) return fail("report.html", w.message());
  const size_t half = run.frames.size() / 2;
  const double mb = run.median(&demo::FrameRecord::ms_bsvtf, half), mf = run.median(&demo::FrameRecord::ms_fmf, half);
  std::printf("  memory      BSVTF %.1f KiB vs FMF %.1f KiB (%.1f%%)\n", run.memory.bsvtf_bytes / 1024.0,
              run.memory.fmf_bytes / 1024.0, 100.0 * run.memory.bsvtf_bytes / std::max<double>(1.0, run.memory.fmf_bytes));
  std::printf("  frame time  BSVTF %.2f ms (incl. feedback) vs FMF %.2f ms: BSVTF at %.2fx the FMF frame rate\n", mb, mf,
              mb > 0 ? mf / mb : 0.0);
  std::printf("  outputs     %s/report.html, report.json, contact_sheet_frames.png, %u frames; %.1f s prepare, %.1f s flight\n",
              cfg->out_dir.c_str(), frames, prep_seconds, run.seconds_flight);

  // 5. Sanity checks (the ctest relies on them): SSIM rises with bytes received and ends high.
  if (!run.frames.empty()) {
    const double first = run.frames.front().ssim, last = run.frames.back().ssim;
    const bool rises = last > first + 0.005 || first > 0.98;
    const bool high = last >= 0.85;
    std::printf("  checks      SSIM first %.4f -> last %.4f: %s\n", first, last, rises && high ? "checks passed" : "FAILED");
    if (!rises || !high) return 1;
  }
  return 0;
}
