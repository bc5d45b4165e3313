// libFuzzer target: the SPMM section reader (factor file kind 5, Spmm::deserialize, paper 003)
// behind the container's CRCs. The input is a list of records
//   u8 tag index (SHAP META DICT CLID SIDX SWGT RMEA RBAS RCOF, else an unknown tag),
//   u16 payload length (little endian, cut to what remains), payload
// framed here into a kind-5 factor file with correct CRCs, so mutations reach the section
// checks (counts, model ids, κ ranges, normals, cluster and slot ids, weights) instead of
// failing the CRC. Every accepted SPMM is evaluated at its first and last texel (analytic part
// at arbitrary directions, residual with every N_PCA switch), serialised again and re-read to
// the same bytes, and packed into the GPU layout, which must pass validate_material. The
// reader bounds every allocation by the input size, so no input allocates much.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "btflod/offline/factor/spmm.hpp"
#include "btflod/offline/packing/spmm_packing.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const uint32_t kTags[] = {btflod::factor_tag("SHAP"), btflod::factor_tag("META"), btflod::factor_tag("DICT"),
                                   btflod::factor_tag("CLID"), btflod::factor_tag("SIDX"), btflod::factor_tag("SWGT"),
                                   btflod::factor_tag("RMEA"), btflod::factor_tag("RBAS"), btflod::factor_tag("RCOF")};
  btflod::FactorFileWriter w(btflod::FactorKind::spmm);
  size_t at = 0;
  int records = 0;
  while (at + 3 <= size && records < 16) {
    const uint8_t which = data[at];
    const size_t len =
        std::min<size_t>(static_cast<size_t>(data[at + 1]) | (static_cast<size_t>(data[at + 2]) << 8), size - at - 3);
    at += 3;
    const uint32_t tag = which < std::size(kTags) ? kTags[which] : btflod::factor_tag("XTRA") + which;
    w.add(tag, std::vector<uint8_t>(data + at, data + at + len));
    at += len;
    ++records;
  }
  const std::vector<uint8_t> file = w.finish();
  auto p = btflod::Spmm::deserialize(file);
  if (!p) return 0;
  const int x1 = p->shape.width - 1, y1 = p->shape.height - 1;
  const auto v1 = static_cast<uint32_t>(p->shape.view_count() - 1);
  const auto l1 = static_cast<uint32_t>(p->shape.light_count() - 1);
  float sink = 0.0f;
  const glm::vec3 wl = glm::normalize(glm::vec3(0.3f, -0.2f, 0.9f)), wv = glm::normalize(glm::vec3(-0.5f, 0.1f, 0.6f));
  sink += p->evaluate_analytic(0, 0, wl, wv).x + p->evaluate_analytic(x1, y1, wv, wl).z;
  for (int n = -1; n <= p->residual_components + 1; ++n)
    sink += p->evaluate_measured(x1, y1, v1, l1, btflod::SpmmEvalOptions{true, n}).y;
  sink += p->evaluate_measured(0, 0, 0, 0, btflod::SpmmEvalOptions{false, -1}).x;
  const std::vector<uint8_t> again = p->serialize();
  auto q = btflod::Spmm::deserialize(again);
  if (!q || q->serialize() != again) std::abort();  // an accepted SPMM must round-trip
  auto packed = btflod::pack_spmm_material(*p);
  if (packed) {
    // Angular tables naming direction 0 everywhere (1 × 1 texel): the material check needs them.
    const uint32_t index[3] = {0, 0, 0};
    const float weight[3] = {1.0f, 0.0f, 0.0f};
    btflod::ShaderConfig config;
    config.angular.resolution = 1;
    const btflod::SpmmMaterialData m = packed->data(btflod::AngularTablesData{1, index, weight, index, weight});
    if (!btflod::validate_material(m, config)) std::abort();  // packing a valid SPMM gives a valid material
    sink += static_cast<float>(btflod::spmm_fragment_fetches(m, static_cast<uint32_t>(x1), static_cast<uint32_t>(y1), 9,
                                                             btflod::spmm_residual_mode(true, -1))
                                   .total());
  }
  volatile float keep = sink;
  (void)keep;
  return 0;
}
