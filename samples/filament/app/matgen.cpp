// btflod-filament-matgen KIND OUT.mat [rgba8] — writes the Filament material source of KIND (bsvtf,
// fmf, feedback) for the sample's configuration (sample_config.hpp), with an RGBA16F tile cache or,
// given rgba8, the compact one (RGBA8 texels and the slot-map table); the build runs matc on it.
#include <cstdio>
#include <cstring>
#include <string>

#include "btflod/runtime/shader/filament_material.hpp"
#include "sample_config.hpp"

int main(int argc, char** argv) {
  using namespace btflod;
  if (argc != 3 && !(argc == 4 && std::strcmp(argv[3], "rgba8") == 0))
    return std::fprintf(stderr, "usage: btflod-filament-matgen bsvtf|fmf|feedback OUT.mat [rgba8]\n"), 2;
  const CacheFormat format = argc == 4 ? CacheFormat::rgba8_affine : CacheFormat::rgba16f;
  const std::string kind = argv[1];
  FilamentMaterialKind k = FilamentMaterialKind::bsvtf;
  if (kind == "fmf")
    k = FilamentMaterialKind::fmf;
  else if (kind == "feedback")
    k = FilamentMaterialKind::feedback;
  else if (kind != "bsvtf")
    return std::fprintf(stderr, "unknown material kind %s\n", argv[1]), 2;
  Result<std::string> mat = generate_filament_material(k, sample::shader_config(format));
  if (!mat) return std::fprintf(stderr, "%s\n", mat.message().c_str()), 1;
  std::FILE* f = std::fopen(argv[2], "wb");
  if (!f || std::fwrite(mat->data(), 1, mat->size(), f) != mat->size() || std::fclose(f) != 0)
    return std::fprintf(stderr, "cannot write %s\n", argv[2]), 1;
  return 0;
}
