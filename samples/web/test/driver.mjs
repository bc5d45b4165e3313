// Browser test driver for the btflod web client: Debian's chromium (headless) through
// puppeteer-core, pages served by nginx (run_web.sh starts it). Runs, for each GL path:
//   golden      priority streaming (feedback → scheduler → Range requests) of every material in a
//               fixed view until converged; final frame vs the CPU reference (PSNR ≥ 40 dB);
//               bytes over time and SSIM vs the converged frame; all .bsvtf requests are Range
//               requests (nginx access log)
//   rgba8       the same golden view with the compact cache (?cacheFormat=rgba8: RGBA8 texels, each
//               slot's affine map in an RGBA32UI slot-map texture) vs the CPU reference that
//               quantises the same tiles (PSNR ≥ 40 dB), and its distance to the rgba16f reference
//   bc5         the same view with ?cacheFormat=bc5 (two RGTC2 planes through
//               EXT_texture_compression_rgtc, offered by both GL paths) vs the CPU reference that
//               BC5-encodes and decodes the same tiles (PSNR ≥ 40 dB) and vs the rgba16f reference,
//               a quarter of the rgba16f texel bytes per tile upload; then with &noRgtc=1 (the
//               extension taken as missing): the page falls back to the rgba8 cache and says so
//   components  the same data in paper 004's component-by-component order: bytes to SSIM 0.95
//   needed      a view of material 0 only: the other materials get only directory and roots
//   faults      every tile's first transfer dropped by the server (444) or served from a copy
//               with corrupted payloads: the page re-requests, converges, and matches the reference
//   bench       wasm tile decode µs of the zstd-coded and the deflate-coded container (zstd and
//               zlib in the page, DecompressionStream inflate, libdeflate under node) vs native in
//               the same run, bit identity of both; frame time at 512² (SwiftShader, llvmpipe)
// The materials are zstd-coded (tile format 3, the default) except the last, deflate-coded
// (format 2, what earlier versions wrote): the golden frames show both formats decoded.
// Writes WORK/report.json and WORK/report.md; exits 1 when a check fails.
import { spawnSync } from 'node:child_process';
import { mkdirSync, readFileSync, writeFileSync, existsSync, readdirSync } from 'node:fs';
import path from 'node:path';
import puppeteer from 'puppeteer-core';

const args = {};
for (let i = 2; i < process.argv.length; ++i) {
  const k = process.argv[i].replace(/^--/, '');
  if (k === 'reduced' || k === 'bench-only') args[k] = true;
  else args[k] = process.argv[++i];
}
const reduced = !!args.reduced;
// --bench-only: only the 512² frame-time pages and the decode benchmark, on SwiftShader and llvmpipe.
const benchOnly = !!args['bench-only'];
const WORK = args.work;
const SIZE = reduced ? 256 : 512;
const report = { reduced, size: SIZE, checks: [], runs: {} };
const check = (name, ok, detail) => {
  report.checks.push({ name, ok, detail });
  console.log(`${ok ? 'PASS' : 'FAIL'} ${name}: ${detail}`);
};
const tool = (...a) => {
  const r = spawnSync(args.tool, a, { encoding: 'utf8' });
  if (r.status !== 0) throw new Error(`btflod-web-tool ${a[0]}: ${r.stderr}`);
  return r.stdout;
};
const fromBase64 = (s) => { const b = Buffer.from(s, 'base64'); return new Float32Array(b.buffer, b.byteOffset, b.length / 4); };
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

const materials = JSON.parse(readFileSync(path.join(args.site, 'data/materials.json'), 'utf8')).materials;
const files = materials.map((m) => path.join(args.site, 'data', m.file));
// Tile format of every tile of a container (byte 0 of each payload: 2 deflate, 3 zstd).
const tileFormats = (file) => {
  const b = readFileSync(file);
  const indexOffset = Number(b.readBigUInt64LE(64)), count = b.readUInt32LE(72);
  const formats = new Set();
  for (let i = 0; i < count; ++i) formats.add(b[Number(b.readBigUInt64LE(indexOffset + 32 * i + 8))]);
  return [...formats];
};
{
  const seen = materials.map((m, i) => ({ coder: m.coder, formats: tileFormats(files[i]) }));
  const want = { zstd: 3, deflate: 2 };
  check('materials: zstd-coded (tile format 3) and deflate-coded (format 2) containers are served',
    seen.every((s) => s.formats.length === 1 && s.formats[0] === want[s.coder]) &&
      seen.some((s) => s.coder === 'zstd') && seen.some((s) => s.coder === 'deflate'),
    seen.map((s, i) => `${materials[i].name}: ${s.coder}, tile formats ${s.formats.join('/')}`).join('; '));
}
const coderFile = (coder) => files[Math.max(0, materials.findIndex((m) => m.coder === coder))];
const zstdFile = coderFile('zstd'), deflateFile = coderFile('deflate');

// Corrupted copies (every payload byte range touched; header and directory intact) for the
// fault test: the server sends them as they are, the client must refuse them by CRC.
mkdirSync(path.join(args.site, 'data-corrupt'), { recursive: true });
for (const f of files) {
  const b = readFileSync(f);
  const payloadOffset = Number(b.readBigUInt64LE(80));
  for (let i = payloadOffset + 40; i < b.length; i += 61) b[i] ^= 0x5a;
  writeFileSync(path.join(args.site, 'data-corrupt', path.basename(f)), b);
}

// The fixed view of the golden runs (LOD bias −3: every visible tile at the finest level, as
// in the GPU golden tests, so the converged frame equals the all-resident CPU reference).
const view = { eye: [0.35, -2.9, 3.3], target: [0, 0.1, 0], fov: 45, light: [-0.5, 0.4, 0.8], lightColor: [1.6, 1.4, 1.2], bias: -3 };
const refPath = path.join(WORK, `reference_${SIZE}.f32`);
tool('reference', '--out', refPath, '--bsvtf', files.join(','), '--eye', view.eye.join(','), '--target', view.target.join(','),
  '--fov', String(view.fov), '--light', view.light.join(','), '--light-color', view.lightColor.join(','), '--size', `${SIZE}x${SIZE}`);
// The same view through the compact cache (rgba8 + per-slot affine map), tile by tile quantised
// as the Streamer's decode jobs do: the reference of the page run with ?cacheFormat=rgba8.
const refRgba8Path = path.join(WORK, `reference_rgba8_${SIZE}.f32`);
tool('reference', '--out', refRgba8Path, '--bsvtf', files.join(','), '--eye', view.eye.join(','), '--target', view.target.join(','),
  '--fov', String(view.fov), '--light', view.light.join(','), '--light-color', view.lightColor.join(','), '--size', `${SIZE}x${SIZE}`,
  '--cache-format', 'rgba8');
// And through the bc5 cache: the same unorm8 texels BC5-encoded as the decode jobs do, decoded
// by the reference decoder (runtime/vt/cache_bc5.hpp).
const refBc5Path = path.join(WORK, `reference_bc5_${SIZE}.f32`);
tool('reference', '--out', refBc5Path, '--bsvtf', files.join(','), '--eye', view.eye.join(','), '--target', view.target.join(','),
  '--fov', String(view.fov), '--light', view.light.join(','), '--light-color', view.lightColor.join(','), '--size', `${SIZE}x${SIZE}`,
  '--cache-format', 'bc5');
const compare = (img, ref = refPath) => {
  const p = path.join(WORK, 'tmp_compare.f32');
  writeFileSync(p, Buffer.from(img.buffer, img.byteOffset, img.byteLength));
  return JSON.parse(tool('compare', '--ref', ref, '--img', p, '--size', `${SIZE}x${SIZE}`));
};
// PCA-k (paper 004): k = 3 views per group, C = 4, one plane at the origin; the tool writes the
// file the page fetches and the CPU reference (reference_pca_views) of the same view.
const pcakView = { eye: [0.3, -2.3, 2.6], target: [0, 0, 0], fov: 45, light: view.light, lightColor: view.lightColor, bias: 0 };
const pcakRef = path.join(WORK, `reference_pcak_${SIZE}.f32`);
const pcakArgs = (size, ref) => ['pcak', '--out', path.join(args.site, 'data', 'pcak-0.pcak'), '--ref', ref, '--k', '3',
  '--components', '4', '--eye', pcakView.eye.join(','), '--target', pcakView.target.join(','), '--fov', '45',
  '--light', pcakView.light.join(','), '--light-color', pcakView.lightColor.join(','), '--size', size];
console.log('  ' + tool(...pcakArgs(`${SIZE}x${SIZE}`, pcakRef)).trim());
{  // corrupted copy of the .pcak: every chunk touched, header and chunk table intact
  const b = readFileSync(path.join(args.site, 'data', 'pcak-0.pcak'));
  const chunks = b.readUInt32LE(36);
  for (let i = 64 + 16 * chunks + 40; i < b.length; i += 61) b[i] ^= 0x5a;
  writeFileSync(path.join(args.site, 'data-corrupt', 'pcak-0.pcak'), b);
}

function launchArgs(gl) {
  const common = ['--headless=new', '--no-sandbox', '--disable-background-networking', '--disable-component-update',
    '--disable-sync', '--no-first-run', '--disable-extensions', '--mute-audio'];
  if (gl === 'swiftshader') return [...common, '--use-angle=swiftshader', '--enable-unsafe-swiftshader'];
  return [...common, '--use-gl=angle', '--use-angle=gl-egl', '--ignore-gpu-blocklist'];
}

async function openPage(browser, query, v = view) {
  const page = await browser.newPage();
  page.btflodConsole = [];  // every console line of the page (the bc5 fallback says why there)
  page.on('console', (m) => {
    page.btflodConsole.push(m.text());
    if (m.type() === 'error' || m.type() === 'warning') console.log(`  [page] ${m.text()}`);
  });
  page.on('pageerror', (e) => console.log(`  [page error] ${e}`));
  const q = new URLSearchParams({ size: String(SIZE), materials: String(materials.length), paused: '1' });
  for (const [k, v] of new URLSearchParams(query || '')) q.set(k, v);
  await page.goto(`${args.url}?${q}`);
  await page.waitForFunction(() => window.btflod && (window.btflod.ready || window.btflod.error), { timeout: 60000 });
  const err = await page.evaluate(() => window.btflod.error || null);
  if (err) throw new Error(`page failed: ${err}`);
  await page.evaluate((v) => {
    window.btflodBase64 = (f32) => {  // float frames travel as base64 (a JSON number array is 10× slower)
      const b = new Uint8Array(f32.buffer, f32.byteOffset, f32.byteLength);
      let s = '';
      for (let i = 0; i < b.length; i += 0x8000) s += String.fromCharCode.apply(null, b.subarray(i, i + 0x8000));
      return btoa(s);
    };
    window.btflod.running = false;  // the driver steps the frames
    Object.assign(window.btflod.client.view, v);
  }, v);
  return page;
}

// The page's "quality so far" compares against the converged frame of its view: the CPU reference.
async function setQualityReference(page, file) {
  await page.evaluate((b64) => {
    const bin = atob(b64);
    const u = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; ++i) u[i] = bin.charCodeAt(i);
    const c = window.btflod.client;
    c.opt.qualityEvery = 1;
    c.setQualityReference(new Float32Array(u.buffer));
  }, readFileSync(file).toString('base64'));
}

// The page's SSIM estimate (64² readback) next to the driver's full-resolution SSIM.
function qualityCheck(gl, what, curve, finalQuality, r) {
  const hitEst = curve.find((p) => p.quality_estimate >= 0.95), hit = curve.find((p) => p.ssim >= 0.95);
  const meanDiff = curve.reduce((a, p) => a + Math.abs(p.quality_estimate - p.ssim), 0) / Math.max(1, curve.length);
  r[`quality_estimate_${what}`] = { final: finalQuality, bytes_to_095_estimate: hitEst ? hitEst.bytes : null,
    bytes_to_095_full: hit ? hit.bytes : null, mean_abs_difference: meanDiff };
  check(`${gl}: ${what} "quality so far" is an SSIM against the converged frame`,
    finalQuality >= 0.98 && curve.length > 1 && curve[0].quality_estimate < 0.95,
    `page estimate ${curve.map((p) => p.quality_estimate.toFixed(3)).slice(0, 8).join(', ')}… final ${finalQuality.toFixed(4)}; ` +
    `bytes to 0.95: estimate ${hitEst ? hitEst.bytes : '-'}, full-resolution SSIM ${hit ? hit.bytes : '-'}; mean |difference| ${meanDiff.toFixed(3)}`);
}

// Steps frames until converged (3 frames in a row) or maxFrames; snapshots every `every` frames.
async function stream(page, { maxFrames, every, snapshots }) {
  let stable = 0, frames = 0;
  const shots = [];
  for (; frames < maxFrames && stable < 3; ++frames) {
    const s = await page.evaluate((snap) => {
      const c = window.btflod.client;
      c.frame();
      const out = { bytes: c.stats.bytes, quality: c.quality(), converged: c.converged(), t: performance.now() };
      if (snap) out.image = window.btflodBase64(c.readColor());
      return out;
    }, snapshots && frames % every === 0);
    if (s.image) shots.push({ bytes: s.bytes, quality: s.quality, image: fromBase64(s.image) });
    stable = s.converged ? stable + 1 : 0;
    await sleep(2);
  }
  const final = await page.evaluate(() => {
    const c = window.btflod.client;
    c.frame();
    return { image: window.btflodBase64(c.readColor()), stats: c.stats, quality: c.quality() };
  });
  return { frames, converged: stable >= 3, shots, final: { ...final, image: fromBase64(final.image) } };
}

function bytesToSsim(shots, finalBytes, target) {
  const curve = shots.map((s) => ({ bytes: s.bytes, quality_estimate: s.quality, ssim: compare(s.image).ssim }));
  const hit = curve.find((p) => p.ssim >= target);
  return { curve, bytes_to_target: hit ? hit.bytes : finalBytes };
}

function accessLog() {
  return readFileSync(args['access-log'], 'utf8').split('\n').filter(Boolean).map((l) => {
    const m = /^(\S+) (\S+) (\d+) (\d+) "([^"]*)" (\S*)$/.exec(l);
    return m ? { method: m[1], uri: m[2], status: Number(m[3]), bytes: Number(m[4]), range: m[5], args: m[6] } : { raw: l };
  });
}
let logMark = 0;
const newLogLines = () => { const all = accessLog(); const fresh = all.slice(logMark); logMark = all.length; return fresh; };

async function runGl(gl) {
  const browser = await puppeteer.launch({ executablePath: args.chromium, headless: 'new', args: launchArgs(gl),
    userDataDir: path.join(WORK, `profile-${gl}-${Date.now()}`) });
  const r = {};
  try {
    if (!benchOnly) await correctness(browser, gl, r);
    if (!reduced || gl === 'swiftshader') await bench(browser, gl, r);
  } finally {
    await browser.close();
  }
  return r;
}

async function correctness(browser, gl, r) {
  {
    // --- golden: priority streaming -------------------------------------------------------
    newLogLines();
    let page = await openPage(browser, '');
    await setQualityReference(page, refPath);
    const pri = await stream(page, { maxFrames: reduced ? 400 : 800, every: reduced ? 4 : 2, snapshots: true });
    const g = compare(pri.final.image);
    r.golden = { frames: pri.frames, converged: pri.converged, psnr_db: g.psnr_db, ssim: g.ssim, stats: pri.final.stats,
      decoded: await page.evaluate(() => window.btflod.client.decodedStats()) };
    const fs = pri.final.stats;
    check(`${gl}: priority streaming converged (asynchronous feedback readback)`, pri.converged && fs.feedbackReadbacks > 0,
      `${pri.frames} frames, ${fs.bytes} bytes; feedback readbacks ${fs.feedbackReadbacks}, fence not yet signalled ` +
      `${fs.feedbackWaits || 0} times, passes skipped (all buffers in flight) ${fs.feedbackSkipped || 0}`);
    check(`${gl}: golden BSVTF vs CPU reference ≥ 40 dB`, g.psnr_db >= 40, `${g.psnr_db.toFixed(2)} dB, SSIM ${g.ssim.toFixed(4)}`);
    const log = newLogLines().filter((l) => l.uri && l.uri.endsWith('.bsvtf'));
    const nonRange = log.filter((l) => l.status !== 206 || !l.range.startsWith('bytes='));
    check(`${gl}: only Range requests for .bsvtf data`, log.length > 0 && nonRange.length === 0,
      `${log.length} requests, ${nonRange.length} without Range/206`);
    const p95 = bytesToSsim(pri.shots, pri.final.stats.bytes, 0.95);
    r.priority_curve = p95.curve;
    qualityCheck(gl, 'BSVTF', p95.curve, pri.final.quality, r);
    await page.close();

    // --- golden: the compact cache (rgba8 + per-slot affine map, half the cache memory) ----
    page = await openPage(browser, '&cacheFormat=rgba8');
    const c8 = await stream(page, { maxFrames: reduced ? 400 : 800, every: 1000, snapshots: false });
    const g8 = compare(c8.final.image, refRgba8Path), g8vs16 = compare(c8.final.image);
    const s8 = c8.final.stats, s16 = pri.final.stats;
    r.golden_rgba8 = { frames: c8.frames, converged: c8.converged, psnr_db: g8.psnr_db, ssim: g8.ssim,
      psnr_vs_rgba16f_reference_db: g8vs16.psnr_db, ssim_vs_rgba16f_reference: g8vs16.ssim,
      cache_bytes: s8.cacheBytes, rgba16f_cache_bytes: s16.cacheBytes, tile_uploads: s8.tileUploads,
      slot_map_uploads: s8.slotMapUploads };
    // Every tile went into the RGBA8 texture with its slot's map (the image is only right when the
    // shader applies the map), and the cache holds half the bytes (plus 16 per slot for the maps).
    check(`${gl}: rgba8 cache: a slot map per tile upload, half the cache memory`,
      s8.tileUploads > 0 && s8.slotMapUploads === s8.tileUploads && s16.slotMapUploads === 0 &&
        s8.cacheBytes < 0.51 * s16.cacheBytes,
      `${s8.tileUploads} tiles, ${s8.slotMapUploads} slot maps; ${s8.cacheBytes} vs ${s16.cacheBytes} bytes`);
    check(`${gl}: golden BSVTF, rgba8 cache, vs the CPU reference reading the same bytes ≥ 40 dB`,
      c8.converged && g8.psnr_db >= 40,
      `${c8.converged ? 'converged' : 'NOT converged'} in ${c8.frames} frames (${JSON.stringify(c8.final.stats)}); ` +
      `${g8.psnr_db.toFixed(2)} dB, SSIM ${g8.ssim.toFixed(4)}; against the rgba16f reference ${g8vs16.psnr_db.toFixed(2)} dB, ` +
      `SSIM ${g8vs16.ssim.toFixed(4)}`);
    await page.close();

    // --- golden: the bc5 cache (two RGTC2 planes + the same slot maps, a quarter of rgba16f) --
    page = await openPage(browser, '&cacheFormat=bc5');
    // More frames allowed than the other formats': frames are stepped with 2 ms pauses while the
    // reads complete asynchronously, and this page comes last, so on a machine loaded by other
    // tests fewer tiles arrive a frame (one run saw 134 of ~500 tiles after 400 frames). The loop
    // stops at convergence, so an idle run takes no longer.
    const c5 = await stream(page, { maxFrames: reduced ? 1600 : 2400, every: 1000, snapshots: false });
    // The rgba16f page's converged frame, the bc5 page's other comparison.
    const page16Path = path.join(WORK, `golden_rgba16f_${gl}.f32`);
    writeFileSync(page16Path, Buffer.from(pri.final.image.buffer, pri.final.image.byteOffset, pri.final.image.byteLength));
    const g5 = compare(c5.final.image, refBc5Path), g5vs16 = compare(c5.final.image), g5vs8 = compare(c5.final.image, refRgba8Path);
    const g5vsPage = compare(c5.final.image, page16Path);
    const s5 = c5.final.stats;
    const perTile = (st) => st.tileUploadBytes / Math.max(1, st.tileUploads);
    r.golden_bc5 = { frames: c5.frames, converged: c5.converged, cache_format: s5.cacheFormat, psnr_db: g5.psnr_db, ssim: g5.ssim,
      psnr_vs_rgba16f_reference_db: g5vs16.psnr_db, ssim_vs_rgba16f_reference: g5vs16.ssim,
      psnr_vs_rgba8_reference_db: g5vs8.psnr_db, psnr_vs_rgba16f_page_db: g5vsPage.psnr_db, cache_bytes: s5.cacheBytes, tile_uploads: s5.tileUploads,
      tile_upload_bytes: s5.tileUploadBytes, rgba16f_tile_upload_bytes_per_tile: perTile(s16) };
    // The compressed texture holds what the page uploaded only if every block went to its slot
    // and plane (the image would be wrong otherwise); a tile is S² · 2 bytes against S² · 8.
    check(`${gl}: bc5 cache: RGTC2 texture, a slot map per tile upload, a quarter of the rgba16f texel bytes`,
      s5.cacheFormat === 'bc5' && s5.cacheFormatFallback === '' && s5.tileUploads > 0 &&
        s5.slotMapUploads === s5.tileUploads && perTile(s5) === perTile(s16) / 4 && s5.cacheBytes < 0.26 * s16.cacheBytes,
      `${s5.cacheFormat}; ${s5.tileUploads} tiles, ${s5.slotMapUploads} slot maps; ${perTile(s5)} vs ${perTile(s16)} bytes a tile; ` +
      `cache ${s5.cacheBytes} vs ${s16.cacheBytes} bytes`);
    // Against the CPU reference decoding the same blocks: the GPU's RGTC2 decode, plane layout and
    // slot maps; against the rgba16f page and reference: what BC5 costs in this view (44.6 dB on
    // SwiftShader and 47.2 dB on llvmpipe against the reference when written; bound 40 dB).
    check(`${gl}: golden BSVTF, bc5 cache, vs the CPU reference reading the same blocks, the rgba16f page and reference ≥ 40 dB`,
      c5.converged && g5.psnr_db >= 40 && g5vsPage.psnr_db >= 40 && g5vs16.psnr_db >= 40,
      `${c5.converged ? 'converged' : 'NOT converged'} in ${c5.frames} frames; ` +
      `${g5.psnr_db.toFixed(2)} dB, SSIM ${g5.ssim.toFixed(4)}; against the rgba16f page ${g5vsPage.psnr_db.toFixed(2)} dB, ` +
      `the rgba16f reference ${g5vs16.psnr_db.toFixed(2)} dB (SSIM ${g5vs16.ssim.toFixed(4)}), ` +
      `the rgba8 reference ${g5vs8.psnr_db.toFixed(2)} dB`);
    await page.close();

    // --- bc5 requested without EXT_texture_compression_rgtc (noRgtc=1): the rgba8 cache ------
    if (gl === 'swiftshader') {
      page = await openPage(browser, '&cacheFormat=bc5&noRgtc=1');
      const cf = await stream(page, { maxFrames: reduced ? 400 : 800, every: 1000, snapshots: false });
      const gf = compare(cf.final.image, refRgba8Path);
      const sf = cf.final.stats;
      const said = page.btflodConsole.filter((l) => l.includes('bc5 → rgba8'));
      r.bc5_fallback = { frames: cf.frames, converged: cf.converged, cache_format: sf.cacheFormat, fallback: sf.cacheFormatFallback,
        psnr_vs_rgba8_reference_db: gf.psnr_db, tile_upload_bytes_per_tile: perTile(sf) };
      check(`${gl}: bc5 without EXT_texture_compression_rgtc falls back to the rgba8 cache and says so`,
        sf.cacheFormat === 'rgba8' && sf.cacheFormatFallback.includes('EXT_texture_compression_rgtc') && said.length === 1 &&
          sf.tileUploads > 0 && sf.slotMapUploads === sf.tileUploads && perTile(sf) === perTile(s16) / 2 &&
          cf.converged && gf.psnr_db >= 40,
        `${sf.cacheFormat} ("${sf.cacheFormatFallback}", console: ${said.length} line); ${perTile(sf)} bytes a tile; ` +
        `vs the rgba8 reference ${gf.psnr_db.toFixed(2)} dB`);
      await page.close();
    }

    // The reduced run's second GL path (llvmpipe) repeats the golden checks only.
    const lite = reduced && gl !== 'swiftshader';
    if (!lite) {
    // --- components: paper 004's order over the same data -------------------------------
    page = await openPage(browser, '');
    await page.evaluate(() => window.btflod.client.startComponentOrder());
    const comp = await stream(page, { maxFrames: reduced ? 600 : 1200, every: reduced ? 3 : 2, snapshots: true });
    const c95 = bytesToSsim(comp.shots, comp.final.stats.bytes, 0.95);
    const gc = compare(comp.final.image);
    r.components_curve = c95.curve;
    r.bytes_to_ssim_095 = { priority: p95.bytes_to_target, components: c95.bytes_to_target };
    check(`${gl}: component order converges to the same frame`, comp.converged && gc.psnr_db >= 40, `${gc.psnr_db.toFixed(2)} dB`);
    console.log(`  bytes to SSIM 0.95: priority ${p95.bytes_to_target}, component by component ${c95.bytes_to_target}`);
    await page.close();
    newLogLines();

    // --- needed: a view of material 0 only ------------------------------------------------
    page = await openPage(browser, '');
    await page.evaluate(() => {
      const c = window.btflod.client;
      c.view.eye = [-1.1 * (c.materials.length - 1), -0.4, 1.5];
      c.view.target = [-1.1 * (c.materials.length - 1), 0.2, 0];
      c.view.bias = 0;
    });
    const need = await stream(page, { maxFrames: 300, every: 1000, snapshots: false });
    const nlog = newLogLines().filter((l) => l.uri && l.uri.endsWith('.bsvtf'));
    const perFile = {};
    for (const l of nlog) perFile[path.basename(l.uri)] = (perFile[path.basename(l.uri)] || 0) + 1;
    const others = materials.slice(1).map((m) => perFile[m.file] || 0);
    // directory: 2 requests; roots: one per virtual texture (2 for C = 8)
    check(`${gl}: materials out of view get directory and roots only`, need.converged && others.every((n) => n <= 4),
      `requests per file ${JSON.stringify(perFile)}`);
    r.needed = { perFile, bytes: need.final.stats.bytes };
    await page.close();
    }

    // --- faults: dropped connections and corrupted payloads --------------------------------
    if (gl === 'swiftshader') {
      // also with the runtime's decoded-ancestor cache bounded to 12 tiles (of 340): decodes start
      // from the deepest ancestor kept, the others are decoded again, and the frame must not change
      newLogLines();
      page = await openPage(browser, '&decodedTiles=12');
      await page.evaluate(() => {
        const seen = new Map();
        let k = 0;
        window.btflod.client.faults = (read, attempt, url) => {
          const key = `${read.material}:${read.offset}`;
          if (seen.has(key)) return null;  // only a tile's first transfer fails
          seen.set(key, true);
          k += 1;
          if (k % 3 === 1) return url + '?drop=1';               // server closes the connection
          if (k % 3 === 2) return url.replace('data/', 'data-corrupt/');  // corrupted payload bytes
          return null;
        };
      });
      const f = await stream(page, { maxFrames: reduced ? 500 : 900, every: 1000, snapshots: false });
      const gf = compare(f.final.image);
      const ds = await page.evaluate(() => window.btflod.client.decodedStats());
      r.decoded_lru = ds;
      check(`${gl}: decoded ancestors bounded (12 tiles)`,
        f.converged && gf.psnr_db >= 40 && ds.capacity === 12 && ds.skipped > 0,
        `capacity ${ds.capacity} tiles (${ds.bytes} bytes), tile levels not decoded again ${ds.skipped}, ` +
        `payload bytes read ${ds.bytesRead}, final ${gf.psnr_db.toFixed(2)} dB`);
      const flog = newLogLines();
      const dropped = flog.filter((l) => l.args && l.args.includes('drop=1')).length;
      const corruptServed = flog.filter((l) => l.uri && l.uri.startsWith('/data-corrupt/')).length;
      r.faults = { frames: f.frames, psnr_db: gf.psnr_db, stats: f.final.stats, dropped, corruptServed };
      check(`${gl}: recovers from dropped connections and corrupt payloads`,
        f.converged && gf.psnr_db >= 40 && f.final.stats.corrupt > 0 && f.final.stats.retries > 0 && dropped > 0,
        `${dropped} connections closed by the server, ${corruptServed} corrupt transfers, refused ${f.final.stats.corrupt}, ` +
        `retries ${f.final.stats.retries}, final ${gf.psnr_db.toFixed(2)} dB`);
      await page.close();
    }

    // --- PCA-k: paper 004's representation, ring search in the shader, component by component ---
    page = await openPage(browser, '&pcak=pcak-0.pcak', pcakView);
    await setQualityReference(page, pcakRef);
    const pk = await stream(page, { maxFrames: 80, every: 1, snapshots: true });
    const gp = compare(pk.final.image, pcakRef);
    const pkFinal = path.join(WORK, `pcak_final_${gl}.f32`);
    writeFileSync(pkFinal, Buffer.from(pk.final.image.buffer, pk.final.image.byteOffset, pk.final.image.byteLength));
    // bytes vs SSIM against the converged frame, one point per delivered component
    const pcurve = [];
    for (const shot of pk.shots)
      if (!pcurve.length || shot.bytes !== pcurve[pcurve.length - 1].bytes)
        pcurve.push({ bytes: shot.bytes, quality_estimate: shot.quality, ssim: compare(shot.image, pkFinal).ssim });
    const hit = pcurve.find((p) => p.ssim >= 0.95);
    qualityCheck(gl, 'PCA-k', pcurve, pk.final.quality, r);
    r.pcak = { psnr_db: gp.psnr_db, ssim: gp.ssim, bytes: pk.final.stats.bytes, frames: pk.frames, curve: pcurve,
      bytes_to_ssim_095: hit ? hit.bytes : pk.final.stats.bytes };
    check(`${gl}: PCA-k streamed component by component converged`, pk.converged && pcurve.length >= 3,
      `${pk.frames} frames, ${pcurve.length} distinct byte counts, ${pk.final.stats.bytes} bytes`);
    check(`${gl}: golden PCA-k (ring search) vs CPU reference ≥ 40 dB`, gp.psnr_db >= 40,
      `${gp.psnr_db.toFixed(2)} dB, SSIM ${gp.ssim.toFixed(4)}`);
    const increasing = pcurve.every((p, i) => i === 0 || p.ssim >= pcurve[i - 1].ssim - 0.02);
    check(`${gl}: PCA-k quality grows as components arrive`, increasing && pcurve[pcurve.length - 1].ssim > 0.999,
      pcurve.map((p) => `${p.bytes} B: ${p.ssim.toFixed(3)}`).join(', '));
    if (r.bytes_to_ssim_095) r.bytes_to_ssim_095.pcak_components = r.pcak.bytes_to_ssim_095;
    console.log(`  PCA-k bytes to SSIM 0.95 vs its converged frame: ${r.pcak.bytes_to_ssim_095} of ${pk.final.stats.bytes}`);
    await page.close();

    if (gl === 'swiftshader') {
      // --- PCA-k faults: each chunk's first transfer dropped or corrupted -----------------------
      newLogLines();
      page = await openPage(browser, '&pcak=pcak-0.pcak', pcakView);
      await page.evaluate(() => {
        const seen = new Set();
        let k = 0;
        window.btflod.client.faults = (info, attempt, url) => {
          if (info.kind !== 2 || info.chunk < 0 || seen.has(info.chunk)) return null;
          seen.add(info.chunk);
          k += 1;
          return k % 2 ? url.replace('data/', 'data-corrupt/') : url + '?drop=1';
        };
      });
      const pf = await stream(page, { maxFrames: 80, every: 1000, snapshots: false });
      const gpf = compare(pf.final.image, pcakRef);
      const flog = newLogLines();
      const corruptServed = flog.filter((l) => l.uri && l.uri === '/data-corrupt/pcak-0.pcak').length;
      r.pcak_faults = { psnr_db: gpf.psnr_db, stats: pf.final.stats, corruptServed };
      check(`${gl}: PCA-k refuses corrupt chunks (CRC) and re-requests dropped ones`,
        pf.converged && gpf.psnr_db >= 40 && pf.final.stats.corrupt === corruptServed && corruptServed > 0 &&
          pf.final.stats.retries > 0,
        `${corruptServed} corrupt transfers, refused ${pf.final.stats.corrupt}, retries ${pf.final.stats.retries}, ` +
        `final ${gpf.psnr_db.toFixed(2)} dB`);
      await page.close();
    }
  }
}

async function bench(browser, gl, r) {
  {
    let page;
    // --- bench: frame time at 512², wasm decode -----------------------------------------------
    if (!reduced) {  // frame-time benchmarks at 512² belong to the full run
      page = await openPage(browser, '&pcak=pcak-0.pcak&size=512', pcakView);
      await stream(page, { maxFrames: 3, every: 1000, snapshots: false });
      r.frame_ms_pcak = await page.evaluate((n) => window.btflod.client.benchmark(n), 20);
      await page.close();
    }
    page = await openPage(browser, reduced ? '' : '&size=512');
    if (!reduced) {
      await stream(page, { maxFrames: 60, every: 1000, snapshots: false });
      r.frame_ms_bsvtf = await page.evaluate((n) => window.btflod.client.benchmark(n), 20);
    }
    if (gl === 'swiftshader') {
      const decodeIn = async (file) => page.evaluate(async (file) => {
        const c = window.btflod.client, M = c.M;
        const head = await fetch(file, { headers: { Range: 'bytes=0-127' } });
        const total = Number(/\/(\d+)/.exec(head.headers.get('Content-Range'))[1]);
        const all = new Uint8Array(await (await fetch(file, { headers: { Range: `bytes=0-${total - 1}` } })).arrayBuffer());
        const p = M._malloc(all.length);
        M.HEAPU8.set(all, p);
        const out = M._malloc(40);
        const status = M._bw_decode_container(p, all.length, 0, 3, out);
        const d = new Float64Array(M.HEAPU8.buffer, out, 5).slice();
        M._free(out);
        M._free(p);
        // DecompressionStream('deflate-raw') on the same tiles' deflate streams (deflate tiles only).
        const view = new DataView(all.buffer);
        const tileCount = view.getUint32(72, true), indexOffset = Number(view.getBigUint64(64, true));
        const info = M._malloc(12);
        let us = 0, n = 0;
        for (let i = 0; i < tileCount; ++i) {
          const e = indexOffset + 32 * i;
          const off = Number(view.getBigUint64(e + 8, true)), size = view.getUint32(e + 16, true);
          const payload = all.subarray(off, off + size);
          const pp = M._malloc(size);
          M.HEAPU8.set(payload, pp);
          M._bw_inflate_container(pp, size, info);
          M._free(pp);
          const [hdr, symbols, coder] = new Uint32Array(M.HEAPU8.buffer, info, 3);
          if (coder !== 0) continue;
          const t0 = performance.now();
          const ds = new Blob([payload.subarray(hdr)]).stream().pipeThrough(new DecompressionStream('deflate-raw'));
          const got = new Uint8Array(await new Response(ds).arrayBuffer());
          us += (performance.now() - t0) * 1000;
          if (got.length !== symbols) return { error: `DecompressionStream gave ${got.length}, expected ${symbols}` };
          n += 1;
        }
        M._free(info);
        return { file, status, hash_lo: d[0], hash_hi: d[1], tiles: d[2] / 3, decode_us: d[3], inflate_us: d[4],
          decompression_stream_us: n ? us / n : null };
      }, file);
      r.decode = await decodeIn('data/' + path.basename(zstdFile));
      r.decode_deflate = await decodeIn('data/' + path.basename(deflateFile));
    }
    await page.close();
  }
}

const gls = ['swiftshader', 'llvmpipe'];  // reduced: llvmpipe runs the golden checks only
if (benchOnly) report.bench_only = true;
for (const gl of gls) {
  try {
    report.runs[gl] = await runGl(gl);
  } catch (e) {
    check(`${gl}: browser run`, false, String(e && e.stack || e));
  }
}

// Native twin of the decode benchmark, same run (the zstd- and the deflate-coded container);
// wasm libdeflate under node (deflate tiles).
const native = JSON.parse(tool('decode', '--bsvtf', zstdFile, '--repeats', '3'));
const nativeDeflate = JSON.parse(tool('decode', '--bsvtf', deflateFile, '--repeats', '3'));
report.native_decode = native;
report.native_decode_deflate = nativeDeflate;
const nodeLd = spawnSync('node', ['--no-experimental-fetch', path.join(path.dirname(new URL(import.meta.url).pathname), 'node_decode.mjs'),
  path.join(args.wasm, 'btflod_web_libdeflate.js'), deflateFile, '3', '1'], { encoding: 'utf8' });
if (nodeLd.status === 0) report.wasm_libdeflate_node = JSON.parse(nodeLd.stdout);
const sw = report.runs.swiftshader;
if (sw && sw.decode && sw.decode_deflate) {
  const same = (w, n) => w.status === 0 && w.hash_lo === n.hash_lo && w.hash_hi === n.hash_hi;
  check('wasm tile decoder bit-identical to native (scalar twin), zstd (format 3) and deflate (format 2) containers',
    same(sw.decode, native) && same(sw.decode_deflate, nativeDeflate),
    `zstd: wasm ${sw.decode.hash_hi}:${sw.decode.hash_lo}, native ${native.hash_hi}:${native.hash_lo}, ${native.tiles} tiles; ` +
    `deflate: wasm ${sw.decode_deflate.hash_hi}:${sw.decode_deflate.hash_lo}, native ${nativeDeflate.hash_hi}:${nativeDeflate.hash_lo}, ` +
    `${nativeDeflate.tiles} tiles`);
  const ds = sw.decode_deflate.decompression_stream_us;
  console.log(`  tile decode µs, zstd container: wasm ${sw.decode.decode_us.toFixed(1)} (zstd ${sw.decode.inflate_us.toFixed(1)}), ` +
    `native scalar ${native.zlib_decode_us.toFixed(1)} (zstd ${native.zlib_inflate_us.toFixed(1)}), native SIMD ${native.simd_decode_us.toFixed(1)}`);
  console.log(`  tile decode µs, deflate container: wasm ${sw.decode_deflate.decode_us.toFixed(1)} (zlib inflate ${sw.decode_deflate.inflate_us.toFixed(1)}), ` +
    `native scalar ${nativeDeflate.zlib_decode_us.toFixed(1)} (inflate ${nativeDeflate.zlib_inflate_us.toFixed(1)}), native SIMD ` +
    `${nativeDeflate.simd_decode_us.toFixed(1)}; DecompressionStream inflate ${ds === null ? '-' : ds.toFixed(1)}`);
} else {
  check('wasm tile decoder bit-identical to native (scalar twin), zstd (format 3) and deflate (format 2) containers', false,
    sw && (sw.decode || sw.decode_deflate) ? JSON.stringify([sw.decode, sw.decode_deflate]) : 'no decode run');
}
for (const gl of gls)
  if (report.runs[gl] && report.runs[gl].frame_ms_bsvtf !== undefined && report.runs[gl].frame_ms_pcak !== undefined)
    console.log(`  frame time 512²: BSVTF ${report.runs[gl].frame_ms_bsvtf.toFixed(1)} ms, PCA-k ${report.runs[gl].frame_ms_pcak.toFixed(1)} ms on ${gl}`);

writeFileSync(path.join(WORK, 'report.json'), JSON.stringify(report, null, 1));
const failed = report.checks.filter((c) => !c.ok);
console.log(failed.length ? `btflod web: ${failed.length} check(s) FAILED` : 'btflod web: all checks passed');
process.exit(failed.length ? 1 : 0);
