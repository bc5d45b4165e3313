// btflod-raytrace — Intel Embree 3 behind btflod's RayTracer concept (offline/render/surface.hpp): one
// triangle geometry per SceneMesh (geometry id = mesh index) sharing the caller's MeshVertex
// and index buffers, closest hit with rtcIntersect1 and any hit with rtcOccluded1. Embree lives
// only in this sample; the library's integrator sees intersect()/occluded().
#pragma once

#include <embree3/rtcore.h>

#include <cstddef>
#include <limits>
#include <memory>
#include <span>
#include <string>

#include "btflod/core/result.hpp"
#include "btflod/offline/render/surface.hpp"

namespace btflod::raytrace {

/// An Embree device and scene over caller-owned meshes (which must outlive it and stay
/// unchanged). build() allocates; intersect()/occluded() are noexcept and thread-safe.
class EmbreeTracer {
 public:
  EmbreeTracer() = default;
  EmbreeTracer(const EmbreeTracer&) = delete;
  EmbreeTracer& operator=(const EmbreeTracer&) = delete;
  EmbreeTracer(EmbreeTracer&& o) noexcept : device_(o.device_), scene_(o.scene_) {
    o.device_ = nullptr, o.scene_ = nullptr;
  }
  ~EmbreeTracer() { release(); }

  /// Validates every mesh (validate_trace_mesh: NaN, degenerate triangles, bad indices are
  /// refused with the mesh named) and builds the BVH with `threads` build threads. Returns
  /// invalid_argument for bad meshes, io_error with Embree's message when Embree fails.
  static Result<std::unique_ptr<EmbreeTracer>> build(std::span<const SceneMesh> meshes, unsigned threads) {
    for (size_t i = 0; i < meshes.size(); ++i)
      if (auto ok = validate_trace_mesh(meshes[i]); !ok)
        return make_error(Status::invalid_argument, "mesh %zu: %s", i, ok.message().c_str());
    auto t = std::make_unique<EmbreeTracer>();
    const std::string config = "threads=" + std::to_string(threads);
    t->device_ = rtcNewDevice(config.c_str());
    if (t->device_ == nullptr)
      return make_error(Status::io_error, "embree: rtcNewDevice failed (%d)", rtcGetDeviceError(nullptr));
    t->scene_ = rtcNewScene(t->device_);
    rtcSetSceneBuildQuality(t->scene_, RTC_BUILD_QUALITY_HIGH);
    for (size_t i = 0; i < meshes.size(); ++i) {
      const SceneMesh& m = meshes[i];
      RTCGeometry g = rtcNewGeometry(t->device_, RTC_GEOMETRY_TYPE_TRIANGLE);
      // MeshVertex starts with its position; Embree reads 16 bytes per vertex, which the
      // following normal covers, so the shared buffer needs no padding.
      rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m.vertices.data(),
                                 offsetof(MeshVertex, position), sizeof(MeshVertex), m.vertices.size());
      rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m.indices.data(), 0,
                                 3 * sizeof(uint32_t), m.indices.size() / 3);
      rtcCommitGeometry(g);
      rtcAttachGeometryByID(t->scene_, g, static_cast<unsigned>(i));
      rtcReleaseGeometry(g);
    }
    rtcCommitScene(t->scene_);
    if (const RTCError e = rtcGetDeviceError(t->device_); e != RTC_ERROR_NONE)
      return make_error(Status::io_error, "embree: scene build failed (error %d)", static_cast<int>(e));
    return t;
  }

  /// Closest hit in (t_min, t_max). noexcept, thread-safe.
  TraceHit intersect(const TraceRay& ray) const noexcept {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh;
    fill(ray, rh.ray);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_, &ctx, &rh);
    TraceHit h;
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
    h.hit = true;
    h.t = rh.ray.tfar;
    h.mesh = rh.hit.geomID;
    h.triangle = rh.hit.primID;
    h.b1 = rh.hit.u;
    h.b2 = rh.hit.v;
    return h;
  }
  /// True when anything lies in (t_min, t_max). noexcept, thread-safe.
  bool occluded(const TraceRay& ray) const noexcept {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r;
    fill(ray, r);
    rtcOccluded1(scene_, &ctx, &r);
    return r.tfar == -std::numeric_limits<float>::infinity();
  }

 private:
  static void fill(const TraceRay& ray, RTCRay& r) noexcept {
    r.org_x = ray.origin.x, r.org_y = ray.origin.y, r.org_z = ray.origin.z;
    r.dir_x = ray.direction.x, r.dir_y = ray.direction.y, r.dir_z = ray.direction.z;
    r.tnear = ray.t_min;
    r.tfar = ray.t_max;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
  }
  void release() noexcept {
    if (scene_ != nullptr) rtcReleaseScene(scene_);
    if (device_ != nullptr) rtcReleaseDevice(device_);
    scene_ = nullptr, device_ = nullptr;
  }

  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
};

static_assert(RayTracer<EmbreeTracer>);

}  // namespace btflod::raytrace
