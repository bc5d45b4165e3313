// The engine runtime in WebAssembly (client/web_streamer.cpp: runtime/streamer.hpp with
// JavaScript-owned I/O) driven as a browser engine would drive it, under Node:
//   * every material of a world in one Streamer; the reads it asks for are served from the
//     files after a random delay, so completions arrive out of order and across frames;
//   * every 13th read fails (io_error) and every 17th arrives with one byte flipped, which the
//     Streamer's CRC check must refuse (tile_failed, bad_data) and fetch again;
//   * the wanted set moves (finest tiles of one quadrant, then of another, then a coarser
//     level everywhere), so tiles are added, swapped out and replaced.
// Checks: every uploaded tile equals an independent decode of its parent chain (bs_reference_
// tile), every wanted tile becomes resident, the page table mirrored from the writes equals a
// rebuild from the cache for every tile of every level, both kinds of fault were seen and
// recovered from, and every material reported ready. Prints one JSON line; exit 1 on failure.
// Usage: node --no-experimental-fetch node_streamer.mjs <btflod_web_streamer.js> <a.bsvtf> [b.bsvtf …]
import { readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const [modulePath, ...paths] = process.argv.slice(2);
if (!modulePath || paths.length === 0) {
  console.error('usage: node_streamer.mjs <btflod_web_streamer.js> <a.bsvtf> [b.bsvtf …]');
  process.exit(2);
}
const require = createRequire(import.meta.url);
const createBtflodStreamer = require(path.resolve(modulePath));
const M = await createBtflodStreamer();
const files = paths.map((p) => readFileSync(p));
const failures = [];
const fail = (msg) => { failures.push(msg); };
const lastError = () => M.UTF8ToString(M._bs_last_error());

// A seeded generator (mulberry32): the same fault schedule every run (the completion order
// also depends on timer jitter).
let seed = 20261203;
const random = () => {
  seed = (seed + 0x6d2b79f5) >>> 0;
  let t = seed;
  t = Math.imul(t ^ (t >>> 15), t | 1);
  t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
  return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
};

const fileCopies = files.map((f) => {
  const p = M._malloc(f.length);
  M.HEAPU8.set(f, p);
  return { ptr: p, len: f.length };
});
// Hostile input first: a truncated directory is refused with a message, and nothing is added.
{
  const bad = M._bs_add_material(fileCopies[0].ptr, 100, files[0].length);
  if (bad >= 0 || lastError().length === 0) fail(`a truncated directory was accepted (${bad})`);
}
for (const [i, f] of files.entries()) {
  const index = M._bs_add_material(fileCopies[i].ptr, f.length, f.length);
  if (index !== i) throw new Error(`${paths[i]}: ${lastError()}`);
}
// A cache smaller than every finest tile of the world: the moves below evict.
const SLOTS_X = 10, SLOTS_Y = 10;
if (M._bs_create(SLOTS_X, SLOTS_Y, 4, 8, 8, 32) !== 0) throw new Error(`bs_create: ${lastError()}`);

const info = (m, level) => {
  const p = M._malloc(6 * 4);
  if (M._bs_material_info(m, level, p) !== 0) throw new Error(lastError());
  const v = Array.from(new Uint32Array(M.HEAPU8.buffer, p, 6));
  M._free(p);
  return { firstTexture: v[0], textures: v[1], finest: v[2], tilesX: v[3], tilesY: v[4], ready: v[5] === 1 };
};
const materials = files.map((_, m) => info(m, 0));
{
  const p = M._malloc(6 * 4);
  if (M._bs_material_info(files.length, 0, p) >= 0) fail('an unknown material was accepted');
  M._free(p);
  M._bs_complete_read(0xffffffff, 0xffffffff, 0);  // an unknown ticket is ignored
  if ((M._bs_slot_of(0xfffffff, 0, 0, 0) >>> 0) !== 0xffffffff) fail('an unknown texture has a slot');
}
const textureCount = materials.reduce((n, m) => n + m.textures, 0);

// The wanted set of a move: per material, (level, x0, x1, y0, y1) in tiles at that level.
const moves = [
  (m) => { const f = info(m, materials[m].finest); return [f.finest, 0, f.tilesX >> 1, 0, f.tilesY >> 1]; },
  (m) => { const f = info(m, materials[m].finest); return [f.finest, f.tilesX >> 1, f.tilesX, f.tilesY >> 1, f.tilesY]; },
  (m) => { const l = Math.max(0, materials[m].finest - 1), f = info(m, l); return [l, 0, f.tilesX, 0, f.tilesY]; },
];
const wantedOf = (move) => files.map((_, m) => moves[move](m));
const wordsOf = (wanted) => {
  const words = [];
  for (const [m, [level, x0, x1, y0, y1]] of wanted.entries())
    for (let y = y0; y < y1; ++y)
      for (let x = x0; x < x1; ++x) words.push(M._bs_feedback_word(m, level, x, y));
  return words;
};
const resident = (wanted) => {
  for (const [m, [level, x0, x1, y0, y1]] of wanted.entries())
    for (let t = 0; t < materials[m].textures; ++t)
      for (let y = y0; y < y1; ++y)
        for (let x = x0; x < x1; ++x)
          if ((M._bs_slot_of(materials[m].firstTexture + t, level, x, y) >>> 0) === 0xffffffff) return false;
  return true;
};

// Engine-owned I/O: reads served from the files after a random delay, some failed or damaged.
let readCount = 0, outstanding = 0, ioFailures = 0, corrupted = 0;
const IO_ERROR = 5;
function serve(r) {
  const [ticketLo, ticketHi, material, offsetLo, offsetHi, size, destination] = r;
  const k = readCount++;
  ++outstanding;
  setTimeout(() => {
    --outstanding;
    if (k % 13 === 5) {
      ++ioFailures;
      M._bs_complete_read(ticketLo, ticketHi, IO_ERROR);
      return;
    }
    const offset = offsetLo + offsetHi * 2 ** 32;
    const bytes = files[material].subarray(offset, offset + size);
    M.HEAPU8.set(bytes, destination);  // M.HEAPU8 read now: the heap may have grown
    if (k % 17 === 7) {
      ++corrupted;
      M.HEAPU8[destination + (k % size)] ^= 0x20;
    }
    M._bs_complete_read(ticketLo, ticketHi, 0);
  }, Math.floor(random() * 4));
}

// Checks of each update's outputs.
const mirror = new Map();  // "texture/mip/x/y" → entry
let uploads = 0, wrongTiles = 0, packetUploads = 0, badDataEvents = 0, ioEvents = 0, readyEvents = 0;
const reference = M._malloc(4 << 20);
function checkOutputs() {
  const tu = M._bs_tile_upload_count();
  const tv = new Uint32Array(M.HEAPU8.buffer, M._bs_tile_uploads(), tu * 6).slice();
  for (let i = 0; i < tu; ++i) {
    const [, texture, level, x, y, texels] = tv.subarray(i * 6, i * 6 + 6);
    let m = 0;
    while (!(texture >= materials[m].firstTexture && texture < materials[m].firstTexture + materials[m].textures)) ++m;
    const local = texture - materials[m].firstTexture;
    const f = fileCopies[m];
    if (M._bs_reference_tile(m, local, level, x, y, f.ptr, f.len, reference) !== 0) {
      fail(`reference decode of ${m}/${local}/${level}/${x}/${y}: ${lastError()}`);
      continue;
    }
    const tileBytes = tileHalves * 2;
    const got = M.HEAPU8.subarray(texels, texels + tileBytes), want = M.HEAPU8.subarray(reference, reference + tileBytes);
    if (Buffer.compare(Buffer.from(got), Buffer.from(want)) !== 0) ++wrongTiles;
    ++uploads;
  }
  packetUploads += M._bs_packet_upload_count();
  const pw = M._bs_page_write_count();
  const pv = new Uint32Array(M.HEAPU8.buffer, M._bs_page_writes(), pw * 5).slice();
  for (let i = 0; i < pw; ++i) mirror.set(`${pv[i * 5]}/${pv[i * 5 + 1]}/${pv[i * 5 + 2]}/${pv[i * 5 + 3]}`, pv[i * 5 + 4]);
  const ec = M._bs_event_count();
  const ev = new Uint32Array(M.HEAPU8.buffer, M._bs_events(), ec * 7).slice();
  for (let i = 0; i < ec; ++i) {
    const [kind, , , , , , status] = ev.subarray(i * 7, i * 7 + 7);
    if (kind === 0) ++readyEvents;
    if (kind === 2 && status === 1) ++badDataEvents;
    if ((kind === 2 || kind === 3) && status === IO_ERROR) ++ioEvents;
  }
}
const tileHalves = M._bs_tile_samples();  // (T + 2B)² × 4 halves per tile

const frames = [];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const feedbackHeap = M._malloc(64 << 10);
let frame = 0;
for (let move = 0; move < moves.length; ++move) {
  const wanted = wantedOf(move);
  const words = wordsOf(wanted);
  new Uint32Array(M.HEAPU8.buffer, feedbackHeap, words.length).set(words);
  let converged = -1;
  for (let f = 0; f < 2000; ++f, ++frame) {
    if (M._bs_update(feedbackHeap, words.length) !== 0) throw new Error(`bs_update: ${lastError()}`);
    checkOutputs();
    const n = M._bs_take_reads();
    const rv = new Uint32Array(M.HEAPU8.buffer, M._bs_reads(), n * 7).slice();
    for (let i = 0; i < n; ++i) serve(rv.subarray(i * 7, i * 7 + 7));
    await sleep(1);
    M._bs_pump(0xffffffff);
    if (resident(wanted) && outstanding === 0 && f > 2) {
      converged = f;
      break;
    }
  }
  frames.push(converged);
  if (converged < 0) fail(`move ${move}: the wanted tiles did not all become resident in 2000 frames`);
}
// Drain the remaining page-table writes, then compare the mirror with a rebuild.
for (let f = 0; f < 8; ++f) {
  M._bs_update(0, 0);
  checkOutputs();
}
let mirrorMismatches = 0, pageTexels = 0;
for (const m of materials)
  for (let t = m.firstTexture; t < m.firstTexture + m.textures; ++t)
    for (let level = 0; level <= m.finest; ++level) {
      const li = info(materials.indexOf(m), level);
      for (let y = 0; y < li.tilesY; ++y)
        for (let x = 0; x < li.tilesX; ++x) {
          ++pageTexels;
          const got = mirror.get(`${t}/${m.finest - level}/${x}/${y}`);
          if (got !== M._bs_page_entry(t, level, x, y) >>> 0) ++mirrorMismatches;
        }
    }
const statsPtr = M._malloc(6 * 8);
M._bs_stats(statsPtr);
const stats = Array.from(new Float64Array(M.HEAPU8.buffer, statsPtr, 6));
const ready = materials.map((_, m) => info(m, 0).ready);

if (wrongTiles) fail(`${wrongTiles} uploaded tiles differ from an independent decode`);
// The first two moves want disjoint finest tiles: each was uploaded at least once.
const tilesWanted = (wanted) =>
  wanted.reduce((n, [, x0, x1, y0, y1], m) => n + (x1 - x0) * (y1 - y0) * materials[m].textures, 0);
const disjointWanted = tilesWanted(wantedOf(0)) + tilesWanted(wantedOf(1));
if (uploads < disjointWanted) fail(`${uploads} tile uploads for ${disjointWanted} distinct wanted tiles`);
if (mirrorMismatches) fail(`${mirrorMismatches} of ${pageTexels} page-table texels differ from a rebuild`);
if (ioFailures === 0 || ioEvents === 0) fail(`failed reads: ${ioFailures} served, ${ioEvents} reported`);
if (corrupted === 0 || badDataEvents === 0) fail(`damaged reads: ${corrupted} served, ${badDataEvents} refused`);
if (!ready.every(Boolean) || readyEvents !== materials.length) fail(`ready: ${ready} (${readyEvents} events)`);
if (packetUploads < textureCount) fail(`${packetUploads} U' packet uploads for ${textureCount} virtual textures`);

console.log(JSON.stringify({
  ok: failures.length === 0, materials: materials.length, virtual_textures: textureCount, frames_to_converge: frames,
  tile_uploads: uploads, distinct_wanted: disjointWanted, wrong_tiles: wrongTiles, packet_uploads: packetUploads, reads: readCount,
  io_failures_served: ioFailures, io_failure_events: ioEvents, damaged_served: corrupted, damaged_refused: badDataEvents,
  page_texels_checked: pageTexels, page_mismatches: mirrorMismatches, bytes_read: stats[0],
  decoded_levels_skipped: stats[2], events_dropped: stats[3], failures,
}));
process.exit(failures.length === 0 ? 0 : 1);
