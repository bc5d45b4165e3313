// btflod viewer page: orbit camera, light direction, material picker, streaming progress
// (bytes received and "quality so far": an SSIM against the converged frame when one is given
// with ?qref=, else the Σw estimate), frame time. window.btflod exposes the
// client to the test driver (samples/web/test/driver.mjs).
import { BtflodClient, PcakClient } from './btflod_client.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);

async function main() {
  const list = await (await fetch('data/materials.json', { cache: 'no-store' })).json();
  const count = Number(params.get('materials') || list.materials.length);
  const urls = list.materials.slice(0, count).map((m) => 'data/' + m.file);
  const module = await createBtflodModule({ locateFile: (f) => 'wasm/' + f });
  const canvas = $('view');
  const size = Number(params.get('size') || 512);
  canvas.width = canvas.height = size;
  const pcak = params.get('pcak');
  const client = pcak ? new PcakClient(canvas, module)
    : new BtflodClient(canvas, module, { streamU: params.get('streamU') !== '0', decodedTiles: Number(params.get('decodedTiles') || 0),
      cacheFormat: params.get('cacheFormat') || 'rgba16f', noRgtc: params.get('noRgtc') === '1' });
  // ?paused=1: no frame runs until a driver steps them (tests set the view first).
  window.btflod = { client, running: params.get('paused') !== '1', lastFrameMs: 0 };
  await client.open(pcak ? 'data/' + pcak : urls);
  const totalBytes = pcak ? client.totalBytes : list.materials.slice(0, count).reduce((s, m) => s + m.bytes, 0);
  // ?qref=FILE: the converged frame of the start view (RGBA float32, canvas size, row 0 = top,
  // e.g. btflod-web-tool reference): "quality so far" becomes an SSIM against it.
  if (params.get('qref')) {
    const r = await fetch(params.get('qref'), { cache: 'no-store' });
    if (r.ok) client.setQualityReference(new Float32Array(await r.arrayBuffer()));
  }

  list.materials.slice(0, count).forEach((m, i) => {
    const o = document.createElement('option');
    o.value = i;
    o.textContent = m.name;
    $('material').appendChild(o);
  });
  $('material').onchange = () => {
    const i = Number($('material').value);
    client.view.target = [-1 + 2.2 * (i - 0.5 * (count - 1)) + 1, 0, 0];
    client.view.distance = 3.0;
  };
  const setLight = () => {
    const az = Number($('lightAz').value) * Math.PI / 180, el = Number($('lightEl').value) * Math.PI / 180;
    client.view.light = [Math.cos(el) * Math.cos(az), Math.cos(el) * Math.sin(az), Math.sin(el)];
  };
  $('lightAz').oninput = $('lightEl').oninput = setLight;
  let drag = null;
  canvas.onmousedown = (e) => { drag = [e.clientX, e.clientY]; };
  window.onmouseup = () => { drag = null; };
  window.onmousemove = (e) => {
    if (!drag) return;
    client.view.eye = null;
    client.view.yaw -= (e.clientX - drag[0]) * 0.01;
    client.view.pitch = Math.min(1.5, Math.max(0.1, client.view.pitch + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
  };
  canvas.onwheel = (e) => {
    e.preventDefault();
    client.view.distance = Math.min(20, Math.max(1.2, client.view.distance * Math.exp(e.deltaY * 0.001)));
  };

  let last = performance.now();
  const tick = () => {
    if (window.btflod.running) {
      const ms = client.frame();
      window.btflod.lastFrameMs = ms;
      const now = performance.now();
      $('ftime').textContent = `${ms.toFixed(1)} ms (interval ${(now - last).toFixed(1)} ms)`;
      last = now;
      $('bytes').textContent = `${(client.stats.bytes / 1024).toFixed(1)} KiB of ${(totalBytes / 1024).toFixed(1)} KiB`;
      const q = client.quality();
      $('quality').textContent = client.qualityRef ? `SSIM ${q.toFixed(3)} against the converged frame`
        : pcak ? `${(100 * q).toFixed(1)} % of the components` : `${(100 * q).toFixed(1)} % (Σw delivered / Σw)`;
      $('fill').style.width = `${(100 * q).toFixed(1)}%`;
      $('reqs').textContent = `${client.stats.requests} (corrupt ${client.stats.corrupt}, retries ${client.stats.retries})`;
    }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
  window.btflod.ready = true;
}

main().catch((e) => {
  $('err').textContent = String(e && e.stack || e);
  window.btflod = Object.assign(window.btflod || {}, { error: String(e) });
});
