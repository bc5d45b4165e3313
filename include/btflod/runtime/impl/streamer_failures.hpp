// btflod — the Streamer's failure policy (StreamerFailurePolicy, runtime/streamer.hpp; docs/vt.md
// "Failures, jobs, quiescing"): a failed start-up job backs off or fails its material, a failed
// request holds its tile or packet back or gives it up, held work returns after its back-off,
// and retry_material() forgets a material's failures. Included by runtime/impl/streamer_impl.hpp;
// compiles alone too.
#pragma once

#include <cstdint>

#include "btflod/runtime/impl/streamer_impl.hpp"

namespace btflod {

// A root or start-up U′ packet job failed: back off, or fail the material.
inline void Streamer::Impl::startup_failed_job(uint32_t j, StreamerOutputs& out) noexcept {
  detail::StreamerJob& job = jobs[j];
  const uint32_t m = job.material, t = job.tile.texture;
  detail::StreamerMaterialState& ms = materials[m];
  const bool packet = job.kind == detail::kPacketJob;
  if (job.status == Status::cancelled) {  // the engine cancelled the read: not a failure
    ++cancelled_count;
    job.state.store(detail::kJobWaiting, std::memory_order_relaxed);
    job.retry_frame = frame + 1;
    return;
  }
  const uint32_t k = t - ms.first_texture;
  uint8_t& fails = packet ? packet_failures[ms.packet_base + k] : tile_failures[record_index(m, k, 0)];
  packet ? ++packet_failure_count : ++tile_failure_count;
  push_event(out, ResidencyEvent{packet ? ResidencyEventKind::packet_failed : ResidencyEventKind::tile_failed, m,
                                 job.tile, job.status});
  if (bump(fails) < config.failure.startup_attempts) {
    job.state.store(detail::kJobWaiting, std::memory_order_relaxed);
    job.retry_frame = frame + backoff_frames(fails);
    return;
  }
  startup_failed[t] |= packet ? 2 : 1;
  job.state.store(detail::kJobFree, std::memory_order_relaxed);
  if (!ms.failed) {
    ms.failed = true;
    ++materials_failed_now;
    scheduler.set_material_enabled(m, false);
    push_event(out, ResidencyEvent{ResidencyEventKind::material_failed, m, job.tile, job.status});
  }
}

// A scheduler request failed (its request is cancelled already): hold the tile or packet back
// for its back-off, or give it up.
inline void Streamer::Impl::request_failed_job(const detail::StreamerJob& job, StreamerOutputs& out) noexcept {
  const uint32_t m = job.material;
  const detail::StreamerMaterialState& ms = materials[m];
  const uint32_t k = job.tile.texture - ms.first_texture;
  if (job.status == Status::cancelled) {
    ++cancelled_count;
    return;
  }
  if (job.kind == detail::kPacketJob) {
    ++packet_failure_count;
    push_event(out, ResidencyEvent{ResidencyEventKind::packet_failed, m, job.tile, job.status});
    const uint32_t fails = bump(packet_failures[ms.packet_base + k]);
    scheduler.hold_u_packets(m, true);
    if (fails >= config.failure.packet_attempts) {
      push_event(out, ResidencyEvent{ResidencyEventKind::packet_unavailable, m, job.tile, job.status});
    } else if (held_count < held.size()) {
      held[held_count++] = detail::HeldWork{m, k, frame + backoff_frames(fails), 1};
    } else {
      scheduler.hold_u_packets(m, false);
    }
    return;
  }
  ++tile_failure_count;
  push_event(out, ResidencyEvent{ResidencyEventKind::tile_failed, m, job.tile, job.status});
  const uint32_t flat = cache.set().levels_of(job.tile.texture).index(job.tile);
  const uint32_t fails = bump(tile_failures[record_index(m, k, flat)]);
  if (fails >= config.failure.tile_attempts) {
    scheduler.hold_tile(job.tile.texture, flat, true);
    ++tiles_unavailable;
    push_event(out, ResidencyEvent{ResidencyEventKind::tile_unavailable, m, job.tile, job.status});
  } else if (held_count < held.size()) {
    scheduler.hold_tile(job.tile.texture, flat, true);
    held[held_count++] = detail::HeldWork{job.tile.texture, flat, frame + backoff_frames(fails), 0};
  }
}

// Held work whose back-off ended may be requested again.
inline void Streamer::Impl::release_held() noexcept {
  for (uint32_t i = 0; i < held_count;) {
    const detail::HeldWork h = held[i];
    if (h.until > frame) {
      ++i;
      continue;
    }
    if (h.packet)
      scheduler.hold_u_packets(h.texture, false);
    else
      scheduler.hold_tile(h.texture, h.flat, false);
    ++retry_count;
    held[i] = held[--held_count];
  }
}

inline Status Streamer::Impl::retry_material(uint32_t m) noexcept {
  if (m >= materials.size() || materials[m].life != detail::kMaterialLive) return Status::invalid_argument;
  detail::StreamerMaterialState& ms = materials[m];
  for (uint32_t k = 0; k < ms.texture_count; ++k) {
    const uint32_t t = ms.first_texture + k;
    for (uint32_t flat = 0; flat < ms.tile_count; ++flat) {
      uint8_t& f = tile_failures[record_index(m, k, flat)];
      if (f >= config.failure.tile_attempts && flat > 0 && scheduler.tile_held(t, flat)) {
        scheduler.hold_tile(t, flat, false);
        --tiles_unavailable;
      }
      f = 0;
    }
    packet_failures[ms.packet_base + k] = 0;
    if (startup_failed[t] & 1) push_startup(t << 1);
    if (startup_failed[t] & 2) push_startup(t << 1 | 1);
    startup_failed[t] = 0;
  }
  for (uint32_t i = 0; i < held_count;) {  // held work of this material: released now
    const detail::HeldWork h = held[i];
    const bool mine = h.packet ? h.texture == m : texture_material[h.texture] == m;
    if (!mine) {
      ++i;
      continue;
    }
    if (!h.packet) scheduler.hold_tile(h.texture, h.flat, false);
    held[i] = held[--held_count];
  }
  scheduler.hold_u_packets(m, false);
  if (ms.failed) {
    ms.failed = false;
    --materials_failed_now;
  }
  return Status::success;
}

}  // namespace btflod
