// btflod-filament-matgen KIND OUT.mat — writes the Filament material source of KIND (bsvtf, fmf,
// feedback) for the sample's configuration (sample_config.hpp); the build runs matc on it.
#include <cstdio>
#include <cstring>
#include <string>

#include "btflod/runtime/shader/filament_material.hpp"
#include "sample_config.hpp"

int main(int argc, char** argv) {
  using namespace btflod;
  if (argc != 3) return std::fprintf(stderr, "usage: btflod-filament-matgen bsvtf|fmf|feedback OUT.mat\n"), 2;
  const std::string kind = argv[1];
  FilamentMaterialKind k = FilamentMaterialKind::bsvtf;
  if (kind == "fmf")
    k = FilamentMaterialKind::fmf;
  else if (kind == "feedback")
    k = FilamentMaterialKind::feedback;
  else if (kind != "bsvtf")
    return std::fprintf(stderr, "unknown material kind %s\n", argv[1]), 2;
  Result<std::string> mat = generate_filament_material(k, sample::shader_config());
  if (!mat) return std::fprintf(stderr, "%s\n", mat.message().c_str()), 1;
  std::FILE* f = std::fopen(argv[2], "wb");
  if (!f || std::fwrite(mat->data(), 1, mat->size(), f) != mat->size() || std::fclose(f) != 0)
    return std::fprintf(stderr, "cannot write %s\n", argv[2]), 1;
  return 0;
}
