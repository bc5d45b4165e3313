// btflod-filament-make-materials OUT_DIR — the offline step of the sample: the three procedural
// materials of procedural_materials.hpp as `.bsvtf` containers, the files the engine streams. A
// measured material comes from btflod-convert (synth/factor/build) the same way.
#include <cstdio>
#include <string>

#include "btflod/core/file_io.hpp"
#include "btflod/offline/build/bsvtf_build.hpp"
#include "procedural_materials.hpp"

using namespace btflod;

int main(int argc, char** argv) {
  if (argc != 2) return std::fprintf(stderr, "usage: btflod-filament-make-materials OUT_DIR\n"), 2;
  for (int m = 0; m < 3; ++m) {
    std::vector<float> directions;
    const EigenTextures e = sample::make_eigen(m, directions);
    BsvtfFromEigenOptions o;
    o.tile_size = sample::kTileSize;
    o.border = 4;
    o.edge = TileEdge::wrap;  // the materials repeat over their objects
    o.material_name = sample::kMaterialNames[m];
    o.light_directions = directions;
    o.view_directions = directions;
    auto file = build_bsvtf_from_eigen_textures(e, o);
    if (!file) return std::fprintf(stderr, "%s: %s\n", o.material_name.c_str(), file.message().c_str()), 1;
    const std::string path = std::string(argv[1]) + "/" + o.material_name + ".bsvtf";
    if (auto w = write_file_bytes(path, *file); !w) return std::fprintf(stderr, "%s\n", w.message().c_str()), 1;
    std::printf("%s: %zu bytes\n", path.c_str(), file->size());
  }
  return 0;
}
