// btflod-label: unit threads
// Tests for runtime/streamer.hpp: the engine's per-frame object. Convergence and exact texels
// against a direct decode of the container, page tables rebuilt from the outputs alone, no
// allocation after creation (global operator new counted) and every buffer through the
// allocator callbacks, moves, asynchronous sources, several materials with different C,
// containers written with the other U row order shading identically, and the outputs forwarded
// to a renderer (runtime/backend/streamer_outputs.hpp).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <deque>
#include <new>
#include <random>
#include <thread>
#include <vector>

#include "btflod/offline/build/bsvtf_build.hpp"
#include "btflod/runtime/backend/streamer_outputs.hpp"
#include "btflod/runtime/stream/thread_executor.hpp"
#include "btflod/runtime/stream/tile_source.hpp"
#include "btflod/runtime/streamer.hpp"
#include "test_runtime_helpers.hpp"

// Counts global allocations (the runtime must not allocate after create()).
#include "test_counting_new.hpp"

using namespace btflod;
using namespace btflod_test;

TEST(RuntimeStreamer, LoadsRootsAndPacketsThenConvergesToTheExactTiles) {
  World w;
  w.add(build(make_eigen(128, 6, 1)));  // C = 6: 2 virtual textures, L = 2
  w.add(build(make_eigen(64, 3, 2)));   // C = 3: 1 virtual texture, L = 1
  w.finish();
  auto r = Streamer::create(w.materials, small_config());
  ASSERT_TRUE(r.ok()) << r.message();
  Streamer s = std::move(r.value());
  EXPECT_EQ(s.texture_count(0), 2u);
  EXPECT_EQ(s.texture_count(1), 1u);
  EXPECT_EQ(s.component_count(1), 3u);
  Engine e(s);
  const auto fb = full_feedback(s);
  run(s, e, fb, 40);
  EXPECT_TRUE(s.material_ready(0));
  EXPECT_TRUE(s.material_ready(1));
  EXPECT_EQ(e.ready.size(), 2u);
  // Every finest tile resident (21 + 21 + 5 tiles ≤ 64 slots).
  for (uint32_t t = 0; t < 3; ++t) {
    const VtLevelTable& lv = s.cache().set().levels_of(t);
    for (uint32_t i = lv.offset[lv.finest_level()]; i < lv.tile_count(); ++i)
      EXPECT_TRUE(s.cache().resident(lv.tile(t, i))) << t << " " << i;
  }
  check_engine(w, s, e);
  // U′ packets as stored: material 0 packet 1 = components 4, 5 (and two zero columns).
  ASSERT_EQ(e.packets[1].size(), size_t{kLights} * kViews * 3 * 4);
  const EigenTextures ref = make_eigen(128, 6, 1);
  for (size_t row = 0; row < size_t{kLights} * kViews * 3; ++row) {
    EXPECT_EQ(e.packets[1][row * 4 + 0], float_to_half_bits(ref.angular[row * 6 + 4]));
    EXPECT_EQ(e.packets[1][row * 4 + 2], 0u);
  }
  EXPECT_EQ(s.pending_page_table_writes(), 0u);
}

TEST(RuntimeStreamer, SwapsUnderPressureKeepTexelsAndPageTablesExact) {
  World w;
  w.add(build(make_eigen(128, 8, 3)));  // 2 textures × 21 tiles, 16 slots
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.cache.slots_x = 4;
  cfg.cache.slots_y = 4;
  auto s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  std::mt19937 rng(3);
  uint64_t swaps = 0;
  for (uint32_t f = 0; f < 120; ++f) {
    std::vector<uint32_t> fb;
    for (int k = 0; k < 6; ++k)
      fb.push_back(
          pack_feedback(FeedbackTile{0, 2, static_cast<uint32_t>(rng() % 4), static_cast<uint32_t>(rng() % 4)}));
    StreamerOutputs o;
    ASSERT_EQ(e.frame(s, fb, o), Status::success);
    swaps += s.scheduler().frame().swaps;
    s.pump();
    check_engine(w, s, e);
  }
  EXPECT_GT(swaps, 10u);
}

TEST(RuntimeStreamer, NoAllocationAfterCreateAndEveryBufferThroughTheCallbacks) {
  World w;
  w.add(build(make_eigen(128, 6, 4)));
  w.finish();
  struct Counter {
    int64_t live = 0;
    uint64_t calls = 0;
  } counter;
  StreamerConfig cfg = small_config();
  cfg.allocator.user = &counter;
  cfg.allocator.allocate = [](void* u, size_t n, size_t a) -> void* {
    auto* c = static_cast<Counter*>(u);
    c->live += static_cast<int64_t>(n);
    ++c->calls;
    return ::operator new(n, std::align_val_t(a), std::nothrow);
  };
  cfg.allocator.deallocate = [](void* u, void* p, size_t n, size_t a) {
    static_cast<Counter*>(u)->live -= static_cast<int64_t>(n);
    ::operator delete(p, std::align_val_t(a), std::nothrow);
  };
  {
    auto s = std::move(Streamer::create(w.materials, cfg).value());
    EXPECT_GT(counter.calls, 10u);
    EXPECT_GT(counter.live, 100000);  // job buffers and decoders live in callback memory
    Engine e(s);
    const auto fb = full_feedback(s);
    std::vector<uint32_t> moving = fb;
    const uint64_t before = btflod_test::global_news();
    for (uint32_t f = 0; f < 60; ++f) {
      moving[f % moving.size()] = pack_feedback(FeedbackTile{0, f % 3, 0, 0});
      StreamerOutputs o = e.outputs();
      ASSERT_EQ(s.update(moving, o), Status::success);
      s.pump();
    }
    EXPECT_EQ(btflod_test::global_news(), before) << "update() or a job allocated";
    EXPECT_GT(s.scheduler().total().uploads, 10u);
  }
  EXPECT_EQ(counter.live, 0);
}

TEST(RuntimeStreamer, MovedStreamerKeepsStreamingAndReplaysDeterministically) {
  World w;
  w.add(build(make_eigen(128, 5, 5)));
  w.finish();
  const auto run_moves = [&](bool move) {
    auto s = std::move(Streamer::create(w.materials, small_config()).value());
    Engine e(s);
    const auto fb = full_feedback(s);
    std::vector<uint64_t> log;
    for (uint32_t f = 0; f < 30; ++f) {
      if (move && f == 7) {
        Streamer moved = std::move(s);
        s = std::move(moved);
      }
      StreamerOutputs o = e.outputs();
      EXPECT_EQ(s.update(fb, o), Status::success);
      for (size_t i = 0; i < o.tile_upload_count; ++i)
        log.push_back(o.tile_uploads[i].tile.key() ^ o.tile_uploads[i].slot);
      for (size_t i = 0; i < o.page_table_write_count; ++i) log.push_back(o.page_table_writes[i].entry);
      e.apply(s, o);
      s.pump();
    }
    check_engine(w, s, e);
    return log;
  };
  const auto a = run_moves(false), b = run_moves(true);
  EXPECT_GT(a.size(), 50u);
  EXPECT_EQ(a, b);
}

TEST(RuntimeStreamer, AsyncSourceAndThreadExecutorConvergeToTheSameTiles) {
  World w;
  w.add(build(make_eigen(128, 6, 6)));
  QueueSource q;
  finish_queued(w, q);
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  Engine e(s);
  const auto fb = full_feedback(s);
  {
    ThreadExecutor executor(s.jobs(), 2);
    for (uint32_t f = 0; f < 80 && (!s.material_ready(0) || s.jobs_in_flight() > 0 || f < 40); ++f) {
      StreamerOutputs o;
      ASSERT_EQ(e.frame(s, fb, o), Status::success);
      q.complete_all(s);
      executor.notify();
      for (int spin = 0; spin < 2000 && s.jobs_in_flight() > 0; ++spin) std::this_thread::yield();
    }
  }
  EXPECT_TRUE(s.material_ready(0));
  EXPECT_GT(s.bytes_read(), 0u);
  check_engine(w, s, e);
}

// A container whose U is stored view-major is delivered in the engine's (light-major) order:
// the packets, hence the shading Σ_k U′(l, v, c, k) V′_k, equal those of the light-major file.
TEST(RuntimeStreamer, OppositeRowOrderContainerShadesIdentically) {
  const EigenTextures ref = make_eigen(64, 5, 7);
  World w;
  w.add(build(ref, AngularRowOrder::light_major));
  w.add(build(ref, AngularRowOrder::view_major));
  w.finish();
  EXPECT_EQ(w.dirs[1].metadata.u_row_order, AngularRowOrder::view_major);
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  Engine e(s);
  run(s, e, full_feedback(s), 20);
  ASSERT_TRUE(s.material_ready(0) && s.material_ready(1));
  for (uint32_t g = 0; g < 2; ++g) EXPECT_EQ(e.packets[s.first_texture(0) + g], e.packets[s.first_texture(1) + g]);
  // Shade one texel at every (light, view) from the delivered packets of the view-major file.
  const float comps[5] = {0.3f, -0.2f, 0.5f, 0.1f, 0.7f};
  for (uint32_t l = 0; l < kLights; ++l)
    for (uint32_t v = 0; v < kViews; ++v)
      for (uint32_t c = 0; c < 3; ++c) {
        double want = 0, got = 0;
        for (uint32_t k = 0; k < 5; ++k) {
          want += double(ref.u(l, v, c, k)) * comps[k];
          const size_t row = (size_t{l} * kViews + v) * 3 + c;
          got += double(half_bits_to_float(e.packets[s.first_texture(1) + k / 4][row * 4 + k % 4])) * comps[k];
        }
        EXPECT_NEAR(got, want, 2e-3) << l << " " << v << " " << c;
      }
}

TEST(RuntimeStreamer, VersionTwoContainerNeedsAnAssumedRowOrder) {
  const EigenTextures ref = make_eigen(64, 4, 8);
  auto pyr = TilePyramid::build(ref, 32, 4).value();
  const auto ld = directions(kLights), vd = directions(kViews);
  BsvtfMetadata md = bsvtf_metadata_for(ref, pyr, ld, vd, "v2");
  auto inputs = bsvtf_tiles_from_pyramid(pyr, md.level_count);
  const auto v3 = read_bsvtf(build_bsvtf(md, ref.angular, inputs.tiles).value()).value();
  // Re-encode the same tiles as a version-2 file.
  std::vector<BsvtfEncodedTile> tiles;
  const auto v3file = build_bsvtf(md, ref.angular, inputs.tiles).value();
  for (const auto& t : v3.tiles)
    tiles.push_back(BsvtfEncodedTile{
        t.id, std::vector<uint8_t>(v3file.begin() + t.offset, v3file.begin() + t.offset + t.size), t.weight});
  md.component_ranges = v3.metadata.component_ranges;
  md.component_scales = v3.metadata.component_scales;
  World w;
  w.add(write_bsvtf(md, ref.angular, tiles, 2).value());
  w.finish();
  EXPECT_EQ(w.dirs[0].header.version, 2u);
  EXPECT_EQ(w.dirs[0].metadata.u_row_order, AngularRowOrder::unspecified);
  auto refused = Streamer::create(w.materials, small_config());
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.message().find("assumed_row_order"), std::string::npos) << refused.message();
  w.materials[0].assumed_row_order = AngularRowOrder::light_major;
  auto s = Streamer::create(w.materials, small_config());
  ASSERT_TRUE(s.ok()) << s.message();
}

TEST(RuntimeStreamer, BadConfigurationsAreRefusedWithAMessage) {
  World w;
  w.add(build(make_eigen(64, 4, 9)));
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.cache.tile_size = 64;
  auto r = Streamer::create(w.materials, cfg);
  EXPECT_EQ(r.status(), Status::invalid_argument);
  EXPECT_NE(r.message().find("border"), std::string::npos);
  EXPECT_EQ(Streamer::create({}, small_config()).status(), Status::invalid_argument);
  auto s = std::move(Streamer::create(w.materials, small_config()).value());
  StreamerOutputs too_small;
  EXPECT_EQ(s.update({}, too_small), Status::invalid_argument);
}

// runtime/backend/streamer_outputs.hpp: every output of an update reaches the sink once, in order —
// tiles in batches of at most kStreamerUploadBatch, then the packets, then the page-table
// writes — and the first failing callback stops the forwarding with its status.
TEST(RuntimeStreamer, ForwardedOutputsArriveInOrderAndAFailureStops) {
  World w;
  w.add(build(make_eigen(128, 6, 1)));
  w.finish();
  StreamerConfig cfg = small_config();
  cfg.scheduler.budgets.uploads_per_frame = 40;  // more tiles per frame than one batch
  cfg.scheduler.budgets.requests_in_flight = 64;
  cfg.scheduler.budgets.tiles_decoding = 64;
  cfg.root_jobs = 2;
  Streamer s = std::move(Streamer::create(w.materials, cfg).value());
  Engine e(s);
  const auto fb = full_feedback(s);
  bool saw_batch_limit = false, saw_packets = false, saw_writes = false;
  for (int f = 0; f < 12; ++f) {
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    std::vector<std::pair<uint32_t, const uint16_t*>> tiles;
    size_t packets = 0, writes = 0;
    const Status st = forward_streamer_outputs(
        o,
        [&](std::span<const TileUpload> batch) noexcept {
          EXPECT_LE(batch.size(), kStreamerUploadBatch);
          EXPECT_EQ(packets + writes, 0u) << "tiles after packets or page-table writes";
          saw_batch_limit = saw_batch_limit || batch.size() == kStreamerUploadBatch;
          for (const TileUpload& t : batch) tiles.emplace_back(t.slot, t.texels.data());
          return Status::success;
        },
        [&](std::span<const PageTableWrite> pt) noexcept {
          EXPECT_EQ(pt.data(), o.page_table_writes.data());
          writes += pt.size();
          return Status::success;
        },
        [&](const StreamerPacketUpload& p) noexcept {
          EXPECT_EQ(writes, 0u) << "a packet after the page-table writes";
          EXPECT_EQ(&p, &o.packet_uploads[packets]);
          ++packets;
          return Status::success;
        });
    ASSERT_EQ(st, Status::success);
    ASSERT_EQ(tiles.size(), o.tile_upload_count);
    for (size_t i = 0; i < tiles.size(); ++i) {
      EXPECT_EQ(tiles[i].first, o.tile_uploads[i].slot);
      EXPECT_EQ(tiles[i].second, o.tile_uploads[i].texels.data());
    }
    EXPECT_EQ(packets, o.packet_upload_count);
    EXPECT_EQ(writes, o.page_table_write_count);
    saw_packets = saw_packets || packets > 0;
    saw_writes = saw_writes || writes > 0;
    if (o.tile_upload_count > 0) {  // a failing upload: nothing after it is forwarded
      size_t calls = 0, later = 0;
      const Status failed = forward_streamer_outputs(
          o,
          [&](std::span<const TileUpload>) noexcept {
            ++calls;
            return Status::io_error;
          },
          [&](std::span<const PageTableWrite>) noexcept {
            ++later;
            return Status::success;
          },
          [&](const StreamerPacketUpload&) noexcept {
            ++later;
            return Status::success;
          });
      EXPECT_EQ(failed, Status::io_error);
      EXPECT_EQ(calls, 1u);
      EXPECT_EQ(later, 0u);
    }
    e.apply(s, o);
    s.pump();
  }
  EXPECT_TRUE(saw_batch_limit);
  EXPECT_TRUE(saw_packets);
  EXPECT_TRUE(saw_writes);
}

// The decoded-ancestor cache (StreamerConfig::decoded_cache_tiles): decode jobs start below
// their deepest cached ancestor, read fewer payload bytes and decode fewer levels, and every
// frame's outputs — tile texels, slots, page-table writes — are the same as without it, under
// swaps; a cache of one entry (constantly replaced while pinned entries are skipped) too.
TEST(RuntimeStreamer, DecodedAncestorCacheGivesTheSameOutputsWithFewerReads) {
  World w;
  w.add(build(make_eigen(256, 8, 5)));  // 2 textures, L = 3: chains of up to 4 levels
  w.finish();
  struct Run {
    Streamer s;
    Engine e;
    explicit Run(Streamer&& st) : s(std::move(st)), e(s) {}
  };
  std::vector<std::unique_ptr<Run>> runs;
  for (const uint32_t tiles : {0u, 16u, 1u}) {
    StreamerConfig cfg = small_config();
    cfg.cache.slots_x = 6;
    cfg.cache.slots_y = 6;  // 36 slots for 2 × 85 tiles: swaps
    cfg.payload_cache_bytes = 0;
    cfg.decoded_cache_tiles = tiles;
    runs.push_back(std::make_unique<Run>(std::move(Streamer::create(w.materials, cfg).value())));
  }
  std::mt19937 rng(5);
  for (uint32_t f = 0; f < 150; ++f) {
    std::vector<uint32_t> fb;
    const uint32_t level = 1 + (f / 10) % 3;
    for (int k = 0; k < 8; ++k)
      fb.push_back(pack_feedback(FeedbackTile{0, level, static_cast<uint32_t>(rng() % (1u << level)),
                                              static_cast<uint32_t>(rng() % (1u << level))}));
    std::vector<StreamerOutputs> outs;
    for (auto& r : runs) {
      outs.push_back(r->e.outputs());
      ASSERT_EQ(r->s.update(fb, outs.back()), Status::success);
    }
    for (size_t i = 1; i < runs.size(); ++i) {
      const StreamerOutputs &a = outs[0], &b = outs[i];
      ASSERT_EQ(a.tile_upload_count, b.tile_upload_count) << "frame " << f;
      for (size_t t = 0; t < a.tile_upload_count; ++t) {
        ASSERT_EQ(a.tile_uploads[t].slot, b.tile_uploads[t].slot);
        ASSERT_TRUE(std::equal(a.tile_uploads[t].texels.begin(), a.tile_uploads[t].texels.end(),
                               b.tile_uploads[t].texels.begin(), b.tile_uploads[t].texels.end()))
            << "frame " << f << " tile " << t;
      }
      ASSERT_EQ(a.page_table_write_count, b.page_table_write_count);
      for (size_t t = 0; t < a.page_table_write_count; ++t)
        ASSERT_EQ(a.page_table_writes[t].entry, b.page_table_writes[t].entry);
    }
    for (size_t i = 0; i < runs.size(); ++i) {
      runs[i]->e.apply(runs[i]->s, outs[i]);
      runs[i]->s.pump();
    }
  }
  check_engine(w, runs[1]->s, runs[1]->e);
  EXPECT_EQ(runs[0]->s.decoded_levels_skipped(), 0u);
  EXPECT_GT(runs[1]->s.decoded_levels_skipped(), 100u);
  EXPECT_GT(runs[2]->s.decoded_levels_skipped(), 0u);
  EXPECT_LT(runs[1]->s.bytes_read(), runs[0]->s.bytes_read());
  std::printf("bytes read: %llu without the decoded cache, %llu with 16 tiles (%llu levels not decoded), %llu with 1\n",
              static_cast<unsigned long long>(runs[0]->s.bytes_read()),
              static_cast<unsigned long long>(runs[1]->s.bytes_read()),
              static_cast<unsigned long long>(runs[1]->s.decoded_levels_skipped()),
              static_cast<unsigned long long>(runs[2]->s.bytes_read()));
}

// core/allocator.hpp's CallbackAllocator: the vote counter (with an accumulation window, so
// every array exists) allocates only through the callbacks — no global operator new while it
// is built — nothing while it counts, and returns every byte when it goes; a copy and a move
// keep using the callbacks.
TEST(RuntimeStreamer, VoteCounterAllocatesOnlyThroughTheCallbacks) {
  struct Counter {
    int64_t live = 0;
    uint64_t calls = 0;
  } counter;
  RuntimeAllocator callbacks;
  callbacks.user = &counter;
  callbacks.allocate = [](void* u, size_t n, size_t a) -> void* {
    auto* c = static_cast<Counter*>(u);
    c->live += static_cast<int64_t>(n);
    ++c->calls;
    return ::operator new(n, std::align_val_t(a), std::nothrow);
  };
  callbacks.deallocate = [](void* u, void* p, size_t n, size_t a) {
    static_cast<Counter*>(u)->live -= static_cast<int64_t>(n);
    ::operator delete(p, std::align_val_t(a), std::nothrow);
  };
  const std::vector<VoteLayout> layouts = {{5, 32, 32}, {3, 8, 8}};
  std::vector<uint32_t> words;
  for (uint32_t i = 0; i < 5000; ++i) words.push_back(pack_feedback(FeedbackTile{i % 2, 3, (i / 7) % 8, (i / 61) % 8}));
  {
    const uint64_t global_before = btflod_test::global_news();
    VoteCounter votes(layouts, VoteWindowConfig{16, 0}, callbacks);
    EXPECT_EQ(btflod_test::global_news(), global_before) << "the vote counter used operator new";
    EXPECT_GE(counter.calls, 11u);
    EXPECT_GT(counter.live, 0);
    const uint64_t calls = counter.calls;
    for (int f = 0; f < 40; ++f) votes.accumulate(std::span<const uint32_t>(words).subspan(f * 100, 1000));
    EXPECT_EQ(counter.calls, calls) << "counting allocated";
    EXPECT_EQ(btflod_test::global_news(), global_before);
    VoteCounter copy = votes;
    EXPECT_GT(counter.calls, calls);
    VoteCounter moved = std::move(copy);
    EXPECT_EQ(moved.votes(0, 0, 0, 0), votes.votes(0, 0, 0, 0));
    EXPECT_EQ(btflod_test::global_news(), global_before);
  }
  EXPECT_EQ(counter.live, 0);
}

namespace {

// A renderer on the CPU reference path: FMF materials hold U′ in FmfMaterialData's layout and
// take packets through write_u_packet (runtime/backend/backend.hpp); tiles and page-table texels are
// kept like Engine does. Everything else is a no-op.
class RecordingBackend final : public Backend {
 public:
  struct Mat {
    uint32_t lights = 0, views = 0, components = 0;
    std::vector<float> u;
    uint32_t packets = 0;
  };
  std::vector<Mat> materials;
  std::vector<std::vector<uint16_t>> slots;
  std::vector<PageTableWrite> writes;
  std::vector<char> order;  // 't' tiles, 'u' packets, 'p' page table
  const char* name() const noexcept override { return "recording CPU backend"; }
  VoidResult init(const ShaderConfig& c, uint32_t) override {
    slots.resize(c.vt.slot_count());
    return {};
  }
  Result<MeshHandle> create_mesh(const MeshData&) override { return MeshHandle{1}; }
  Result<MaterialHandle> create_material(const FmfMaterialData& d) override {
    materials.push_back(Mat{d.light_count, d.view_count, d.components,
                            std::vector<float>(d.eigen_abrdfs.begin(), d.eigen_abrdfs.end()), 0});
    return MaterialHandle{static_cast<uint32_t>(materials.size())};
  }
  Status destroy_material(MaterialHandle h) override {
    if (h.id == 0 || h.id > materials.size() || materials[h.id - 1].components == 0) return Status::invalid_argument;
    materials[h.id - 1] = Mat{};
    return Status::success;
  }
  Status upload_tiles(std::span<const TileUpload> tiles) noexcept override {
    for (const TileUpload& t : tiles) slots[t.slot].assign(t.texels.begin(), t.texels.end());
    order.push_back('t');
    return Status::success;
  }
  Status upload_u_packets(MaterialHandle h, std::span<const UPacketUpload> packets) noexcept override {
    if (h.id == 0 || h.id > materials.size()) return Status::invalid_argument;
    Mat& m = materials[h.id - 1];
    for (const UPacketUpload& p : packets)
      if (check_u_packet(p, m.lights, m.views, m.components) != Status::success) return Status::invalid_argument;
    for (const UPacketUpload& p : packets) {
      EXPECT_EQ(write_u_packet(p, m.lights, m.views, m.components, m.u), Status::success);
      ++m.packets;
    }
    order.push_back('u');
    return Status::success;
  }
  Status apply_page_table_writes(std::span<const PageTableWrite> w) noexcept override {
    writes.insert(writes.end(), w.begin(), w.end());
    order.push_back('p');
    return Status::success;
  }
  Status begin_frame(const FrameDesc&) noexcept override { return Status::success; }
  Status draw(ShaderProgram, MeshHandle, MaterialHandle, const ShaderParams&) noexcept override {
    return Status::success;
  }
  Status draw_feedback(MeshHandle, const ShaderParams&) noexcept override { return Status::success; }
  Status end_frame() noexcept override { return Status::success; }
  bool poll_feedback(FeedbackFrame&) noexcept override { return false; }
  uint32_t feedback_ring_size() const noexcept override { return 1; }
  uint64_t dropped_feedback() const noexcept override { return 0; }
  Status read_color(ImageView<float>) noexcept override { return Status::success; }
  Status wait_idle() noexcept override { return Status::success; }
};

// U′ of e (light-major, FmfMaterialData's layout) rounded to half, as the packets carry it.
std::vector<float> half_rounded(const std::vector<float>& u) {
  std::vector<float> out(u.size());
  for (size_t i = 0; i < u.size(); ++i) out[i] = half_bits_to_float(float_to_half_bits(u[i]));
  return out;
}

}  // namespace

// apply_streamer_outputs(Backend&, outputs, handles): every U′ packet reaches the backend
// material of its Streamer material through Backend::upload_u_packets, in the backend's
// light-major layout, also from a view-major container; materials created with U′ = 0 end up
// with exactly the container's U′ (as halves), each packet once. Tiles go first, page-table
// texels last. A packet whose material has no handle is refused.
TEST(RuntimeStreamer, ApplyToBackendUploadsEveryPacketIntoItsMaterial) {
  const EigenTextures e0 = make_eigen(64, 6, 3), e1 = make_eigen(64, 9, 4), e2 = make_eigen(64, 6, 8);
  World w;
  w.add(build(e0));
  w.add(build(e1, AngularRowOrder::view_major));
  w.add(build(e2));
  w.finish();
  Streamer s = std::move(Streamer::create(w.materials, small_config()).value());
  RecordingBackend be;
  ShaderConfig sc;
  sc.vt.slots_x = 8;
  sc.vt.slots_y = 8;
  ASSERT_TRUE(be.init(sc, s.cache().set().texture_count()).ok());
  std::vector<MaterialHandle> handles;
  const EigenTextures* es[3] = {&e0, &e1, &e2};
  // Created in reverse, so handle i + 1 is not Streamer material i: the mapping is used.
  std::vector<std::vector<float>> zeros;
  for (int m = 2; m >= 0; --m) {
    zeros.emplace_back(es[m]->angular.size(), 0.0f);
    FmfMaterialData d;
    d.components = es[m]->components();
    d.light_count = kLights;
    d.view_count = kViews;
    d.eigen_abrdfs = zeros.back();
    handles.insert(handles.begin(), be.create_material(d).value());
  }
  Engine e(s);
  const auto fb = full_feedback(s);
  for (int f = 0; f < 30; ++f) {
    StreamerOutputs o = e.outputs();
    ASSERT_EQ(s.update(fb, o), Status::success);
    be.order.clear();
    ASSERT_EQ(apply_streamer_outputs(be, o, handles), Status::success);
    if (o.packet_upload_count > 0 && o.tile_upload_count > 0) {
      // tiles, then packets, then page-table texels
      EXPECT_EQ(be.order.front(), 't');
      EXPECT_EQ(be.order.back(), o.page_table_write_count > 0 ? 'p' : 'u');
    }
    e.apply(s, o);
    if (o.packet_upload_count > 0) {  // the same outputs without a handle for a material: refused
      const std::vector<MaterialHandle> few(handles.begin(), handles.begin() + o.packet_uploads[0].material);
      RecordingBackend other;
      ASSERT_TRUE(other.init(sc, 1).ok());
      EXPECT_EQ(apply_streamer_outputs(other, o, few), Status::invalid_argument);
    }
    s.pump();
  }
  for (uint32_t m = 0; m < 3; ++m) {
    ASSERT_TRUE(s.material_ready(m));
    const RecordingBackend::Mat& bm = be.materials[handles[m].id - 1];
    EXPECT_EQ(bm.packets, s.texture_count(m)) << "material " << m;
    EXPECT_EQ(bm.u, half_rounded(es[m]->angular)) << "material " << m;
  }
  EXPECT_NE(be.materials[handles[0].id - 1].u, be.materials[handles[2].id - 1].u);
}

// The two CPU twins of a U′ upload agree with the material packing: write_u_packet builds
// FmfMaterialData's U′ and u_packet_to_rgba_layers the eigen_abrdfs texture layers exactly as
// pack_eigen_abrdfs_rgba packs that U′ (C = 6: the second packet is partial); bad packets are
// refused without writing.
TEST(RuntimeStreamer, UPacketTwinsMatchTheMaterialPacking) {
  const uint32_t C = 6, L = 3, V = 5, rows = L * V * 3;
  std::vector<float> u(size_t{rows} * C);
  for (size_t i = 0; i < u.size(); ++i)
    u[i] = half_bits_to_float(float_to_half_bits(0.01f * static_cast<float>(i) - 1.0f));
  std::vector<std::vector<uint16_t>> packets(2, std::vector<uint16_t>(size_t{rows} * 4, 0));
  for (uint32_t r = 0; r < rows; ++r)
    for (uint32_t c = 0; c < C; ++c) packets[c / 4][size_t{r} * 4 + c % 4] = float_to_half_bits(u[size_t{r} * C + c]);
  std::vector<float> built(u.size(), 0.0f);
  FmfMaterialData d;
  d.components = C;
  d.light_count = L;
  d.view_count = V;
  d.eigen_abrdfs = u;
  const std::vector<float> rgba = pack_eigen_abrdfs_rgba(d);
  const size_t plane = size_t{L} * V * 4;
  for (uint32_t g = 0; g < 2; ++g) {
    const UPacketUpload p{g, rows, packets[g]};
    ASSERT_EQ(write_u_packet(p, L, V, C, built), Status::success);
    std::vector<float> layers(plane * 4, -1.0f);
    const uint32_t n = u_packet_to_rgba_layers(p, L, V, C, layers);
    ASSERT_EQ(n, g == 0 ? 4u : 2u);
    for (size_t i = 0; i < plane * n; ++i)
      ASSERT_EQ(layers[i], rgba[4 * g * plane + i]) << "packet " << g << " float " << i;
  }
  EXPECT_EQ(built, u);
  const std::vector<float> before = built;
  const UPacketUpload bad[3] = {{2, rows, packets[0]},
                                {0, rows - 3, std::span<const uint16_t>(packets[0]).first((rows - 3) * 4)},
                                {0, rows, std::span<const uint16_t>(packets[0]).first(4)}};
  for (const UPacketUpload& p : bad) {
    EXPECT_EQ(write_u_packet(p, L, V, C, built), Status::invalid_argument);
    std::vector<float> layers(plane * 4);
    EXPECT_EQ(u_packet_to_rgba_layers(p, L, V, C, layers), 0u);
  }
  std::vector<float> small(plane);
  EXPECT_EQ(u_packet_to_rgba_layers(UPacketUpload{0, rows, packets[0]}, L, V, C, small), 0u);
  EXPECT_EQ(built, before);
}
