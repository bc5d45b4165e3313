// btflod — applying one Streamer::update()'s outputs (runtime/streamer.hpp) to a renderer: the
// per-frame glue every engine would otherwise write itself.
//
// Order matters and is fixed here: tiles are copied into their cache slots first, then the U′
// packets into their materials, then the page-table texels are written, so a texel never points
// at a slot whose tile has not been uploaded in the same frame (all go through one command
// stream on a GPU). forward_streamer_outputs() hands each kind to a caller's function (U′ may
// live wherever the engine's shaders read it); apply_streamer_outputs() applies all three to a
// Backend (Backend::upload_tiles, upload_u_packets, apply_page_table_writes), the caller naming
// the backend material of each Streamer material.
//
// Everything here is per-frame code: noexcept, no allocation (tiles are forwarded in batches
// through a fixed array on the stack).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "btflod/core/result.hpp"
#include "btflod/runtime/backend/backend.hpp"
#include "btflod/runtime/streamer.hpp"

namespace btflod {

/// Tiles forwarded per Backend::upload_tiles() call by apply_streamer_outputs().
inline constexpr size_t kStreamerUploadBatch = 32;

/// Calls `upload_tiles(std::span<const TileUpload>)` with the tile uploads of `out`, in order, in
/// batches of at most kStreamerUploadBatch tiles of one cache pool (TileUpload::pool), then `upload_packet(const
/// StreamerPacketUpload&)` for each U′ packet, in order, then `write_page_table(std::span<const PageTableWrite>)` once
/// with every page-table write of `out` (when there is any). Returns the first non-success Status a callback returned
/// (later callbacks are not called), else success. Preconditions: `out` was filled by Streamer::update() and that
/// Streamer has not been updated since (the texel spans point into its job buffers). noexcept when the callbacks are;
/// no allocation; same thread as the update.
template <class UploadTiles, class WritePageTable, class UploadPacket>
Status forward_streamer_outputs(const StreamerOutputs& out, UploadTiles&& upload_tiles,
                                WritePageTable&& write_page_table, UploadPacket&& upload_packet) noexcept {
  TileUpload batch[kStreamerUploadBatch];
  size_t n = 0;
  for (size_t i = 0; i < out.tile_upload_count; ++i) {
    const StreamerTileUpload& u = out.tile_uploads[i];
    batch[n++] = TileUpload{u.slot, u.texels, u.unorm8, u.map, u.bc5, u.pool};
    // A batch holds tiles of one pool (one cache texture).
    if (n == kStreamerUploadBatch || i + 1 == out.tile_upload_count || out.tile_uploads[i + 1].pool != u.pool) {
      if (const Status s = upload_tiles(std::span<const TileUpload>(batch, n)); s != Status::success) return s;
      n = 0;
    }
  }
  for (size_t i = 0; i < out.packet_upload_count; ++i)
    if (const Status s = upload_packet(out.packet_uploads[i]); s != Status::success) return s;
  if (out.page_table_write_count > 0)
    return write_page_table(std::span<const PageTableWrite>(out.page_table_writes.data(), out.page_table_write_count));
  return Status::success;
}

/// forward_streamer_outputs() without a packet function: U′ packets are ignored (a renderer
/// whose materials already hold all of U′ and never stream it).
template <class UploadTiles, class WritePageTable>
Status forward_streamer_outputs(const StreamerOutputs& out, UploadTiles&& upload_tiles,
                                WritePageTable&& write_page_table) noexcept {
  return forward_streamer_outputs(out, upload_tiles, write_page_table,
                                  [](const StreamerPacketUpload&) noexcept { return Status::success; });
}

/// The backend's view of a Streamer packet (runtime/streamer.hpp → runtime/backend/backend.hpp).
constexpr UPacketUpload to_u_packet_upload(const StreamerPacketUpload& p) noexcept {
  return UPacketUpload{p.packet, p.rows, p.halves};
}

/// Applies `out` to a GPU backend: Backend::upload_tiles() for the tiles (batched, in order),
/// Backend::upload_u_packets() for each U′ packet into `materials[packet.material]` (the
/// backend's FMF material of that Streamer material, created with the Streamer's light-major
/// U′ layout — StreamerConfig::u_row_order must be light_major), then
/// Backend::apply_page_table_writes() for the page-table texels. Returns invalid_argument when a
/// packet names a material at or past materials.size() or whose handle is empty (tiles already
/// uploaded stay), else the backend's first failure, else success. Preconditions: the backend
/// was initialised (Backend::init) with the Streamer's cache configuration and
/// streamer.cache().set().texture_count() virtual textures; `out` comes from the latest
/// update(). Threading: the backend's thread. noexcept, no allocation.
inline Status apply_streamer_outputs(Backend& backend, const StreamerOutputs& out,
                                     std::span<const MaterialHandle> materials) noexcept {
  return forward_streamer_outputs(
      out, [&](std::span<const TileUpload> tiles) noexcept { return backend.upload_tiles(tiles); },
      [&](std::span<const PageTableWrite> writes) noexcept { return backend.apply_page_table_writes(writes); },
      [&](const StreamerPacketUpload& p) noexcept {
        if (p.material >= materials.size() || materials[p.material].id == 0) return Status::invalid_argument;
        const UPacketUpload u = to_u_packet_upload(p);
        return backend.upload_u_packets(materials[p.material], std::span<const UPacketUpload>(&u, 1));
      });
}

}  // namespace btflod
