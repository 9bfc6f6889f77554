// The review page's script (web/review/review.html): the clip list, and the 3-D player of one
// clip's skeleton before and after cleaning. Units a person reads: cm, degrees, Hz, frames.
// The page writes its state into #status (data-state = ready | drawn | error) for the browser test.
const statusEl = document.getElementById('status');
function setStatus(state, text, extra = {}) {
  statusEl.dataset.state = state;
  statusEl.textContent = text;
  for (const [k, v] of Object.entries(extra)) statusEl.dataset[k] = String(v);
}
window.addEventListener('error', (e) => {
  // Chromium reports a resize that lands during layout as an error; it is not one of ours.
  if (/ResizeObserver loop/.test(e.message)) return;
  setStatus('error', 'error: ' + (e.message || e));
});
window.addEventListener('unhandledrejection', (e) => setStatus('error', 'error: ' + (e.reason && e.reason.message || e.reason)));

const run = JSON.parse(document.getElementById('run-data').textContent);
const clips = JSON.parse(document.getElementById('clips-data').textContent);
const $ = (id) => document.getElementById(id);
const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]));
const fmt = (v, d = 2) => (v === undefined || v === null || !isFinite(v)) ? '' : Number(v).toFixed(d);
const ratio = (a, b) => (a > 0 && b !== undefined) ? b / a : undefined;

// ---- the list ----------------------------------------------------------------------------
const JITTER_WORSE = 1.05, SKATING_WORSE = 1.25;  // engine/motion_check.hpp
for (const c of clips) {
  c.seconds = c.fps > 0 ? c.frames / c.fps : 0;
  c.jitter_ratio = ratio(c.jitter_before, c.jitter_after);
  c.skating_ratio = c.contact_steps > 0 ? ratio(c.skating_before, c.skating_after) : undefined;
  c.worse = (c.jitter_ratio > JITTER_WORSE) || (c.skating_ratio > SKATING_WORSE);
}
const columns = [
  { key: 'name', label: 'clip', cls: 'name', title: 'source file' },
  { key: 'change_rms', label: 'change cm', title: 'RMS displacement of all joints, before to after, cm', fmt: (c) => fmt(c.change_rms, 2) },
  { key: 'change_max', label: 'max cm', title: 'largest displacement of one joint (frame, joint), cm', fmt: (c) => fmt(c.change_max, 1) },
  { key: 'method', label: 'method', cls: 'text', title: 'method used on this clip (auto: chosen from its noise)' },
  { key: 'noise_deg', label: 'noise °', title: 'estimated rotation noise, degrees', fmt: (c) => fmt(c.noise_deg, 2) },
  { key: 'pops', label: 'pops', title: 'pops found (repaired unless --pops detect)', fmt: (c) => c.pops || '' },
  { key: 'garbage_count', label: 'garbage', title: 'garbage joints (uncaptured: constant or flipping)', fmt: (c) => c.garbage_count || '' },
  { key: 'contacts', label: 'contacts', title: 'foot contacts found', fmt: (c) => c.contacts || '' },
  { key: 'jitter_before', label: 'jitter before', title: 'RMS joint acceleration, cm/s², as read', fmt: (c) => fmt(c.jitter_before, 0) },
  { key: 'jitter_after', label: 'after', title: 'RMS joint acceleration, cm/s², as written', fmt: (c) => fmt(c.jitter_after, 0) },
  { key: 'jitter_ratio', label: '×', title: 'jitter after / before', fmt: (c) => ratioCell(c.jitter_ratio, JITTER_WORSE) },
  { key: 'skating_before', label: 'skating before', title: 'mean foot sliding during contacts, cm/s, as read', fmt: (c) => fmt(c.skating_before, 1) },
  { key: 'skating_after', label: 'after', title: 'mean foot sliding during contacts, cm/s, as written', fmt: (c) => fmt(c.skating_after, 1) },
  { key: 'skating_ratio', label: '×', title: 'skating after / before', fmt: (c) => ratioCell(c.skating_ratio, SKATING_WORSE) },
  { key: 'frames', label: 'frames', title: 'frames', fmt: (c) => c.frames },
  { key: 'seconds', label: 's', title: 'duration, seconds', fmt: (c) => fmt(c.seconds, 1) },
  { key: 'fps', label: 'Hz', title: 'frame rate', fmt: (c) => fmt(c.fps, 0) },
];
function ratioCell(r, worse) {
  if (r === undefined) return '';
  const cls = r > worse ? 'worse' : r < 1 ? 'better' : '';
  return `<span class="${cls}">${r.toFixed(2)}</span>`;
}
let sortKey = 'change_rms', sortDir = -1;  // the clips cleaning changed most first
function renderHead() {
  $('clips').tHead.innerHTML = '<tr>' + columns.map((col) =>
    `<th data-key="${col.key}" class="${col.cls || ''}${col.key === sortKey ? (sortDir > 0 ? ' sorted-asc' : ' sorted-desc') : ''}" title="${esc(col.title)}">${esc(col.label)}</th>`).join('') + '</tr>';
}
function renderList() {
  const words = $('filter').value.toLowerCase().split(/\s+/).filter(Boolean);
  const shown = clips.filter((c) => {
    if ($('only-pops').checked && !c.pops) return false;
    if ($('only-worse').checked && !c.worse) return false;
    if ($('only-garbage').checked && !c.garbage_count) return false;
    const hay = (c.name + ' ' + c.method + ' ' + c.pop_joints + ' ' + c.garbage + ' ' + c.parameters).toLowerCase();
    return words.every((w) => hay.includes(w));
  });
  shown.sort((a, b) => {
    const x = a[sortKey], y = b[sortKey];
    if (typeof x === 'string' || typeof y === 'string') return sortDir * String(x ?? '').localeCompare(String(y ?? ''));
    const xv = (x === undefined || x === null) ? -Infinity : x, yv = (y === undefined || y === null) ? -Infinity : y;
    return sortDir * (xv - yv) || a.i - b.i;
  });
  const rows = shown.map((c) => '<tr data-i="' + c.i + '">' + columns.map((col) => {
    if (col.key === 'name') return `<td class="name"><a title="${esc(c.pop_joints ? 'pops: ' + c.pop_joints : 'open the player')}">${esc(c.name)}</a></td>`;
    const v = col.fmt ? col.fmt(c) : esc(c[col.key] ?? '');
    return `<td class="${col.cls || ''}">${v}</td>`;
  }).join('') + '</tr>');
  $('clips').tBodies[0].innerHTML = rows.join('');
  $('shown').textContent = `${shown.length} of ${clips.length} clips`;
}
function renderRun() {
  const worse = clips.filter((c) => c.worse).length;
  const pops = clips.reduce((s, c) => s + c.pops, 0);
  $('run-line').textContent = `${run.command}: ${clips.length} clips` +
    (run.method ? `, --method ${run.method}` : '') +
    `, ${pops} pops in ${clips.filter((c) => c.pops).length} clips` +
    (worse ? `, ${worse} clips worse in jitter or skating` : '') +
    (run.failed.length ? `, ${run.failed.length} failed` : '') +
    (run.kept ? `, ${run.kept} kept from an earlier run (not on this page)` : '') +
    (run.interrupted ? ', interrupted' : '');
  if (run.failed.length)
    $('failures').innerHTML = '<b>failed:</b> ' + run.failed.map((f) => `${esc(f.clip)}: ${esc(f.error)}`).join('<br>');
}
$('clips').tHead.addEventListener('click', (e) => {
  const th = e.target.closest('th');
  if (!th) return;
  const key = th.dataset.key;
  sortDir = key === sortKey ? -sortDir : (key === 'name' || key === 'method' ? 1 : -1);
  sortKey = key;
  renderHead();
  renderList();
});
$('clips').tBodies[0].addEventListener('click', (e) => {
  const tr = e.target.closest('tr');
  if (tr) location.hash = 'clip=' + tr.dataset.i;
});
for (const id of ['filter', 'only-pops', 'only-worse', 'only-garbage']) $(id).addEventListener('input', renderList);
renderRun();
renderHead();
renderList();
setStatus('ready', `ready: ${clips.length} clips`, { clips: clips.length, ms: Math.round(performance.now()) });

// ---- clip data: clips/N.js calls mocapReviewClip(i, meta, base64) --------------------------
const pending = new Map();
window.mocapReviewClip = (i, meta, data) => {
  const p = pending.get(i);
  if (p) decode(meta, data).then(p.resolve, p.reject);
};
// engine/run/review_report.cpp pack(): deflate, then byte planes (low, high), then int16 steps from
// the value one sample (J x 3 values) before.
async function decode(meta, data) {
  const bytes = Uint8Array.from(atob(data), (ch) => ch.charCodeAt(0));
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('deflate'));
  const planes = new Uint8Array(await new Response(stream).arrayBuffer());
  const total = planes.length / 2, row = meta.joints.length * 3;
  const q = new Int16Array(total);
  for (let k = 0; k < total; ++k) q[k] = (planes[k] | (planes[total + k] << 8)) + (k >= row ? q[k - row] : 0);
  const n = meta.count * row;
  const f32 = (offset, scale) => { const out = new Float32Array(n); for (let k = 0; k < n; ++k) out[k] = q[offset + k] * scale; return out; };
  meta.pos = [f32(0, meta.position_scale), f32(n, meta.position_scale)];
  meta.ang = [f32(2 * n, meta.angle_scale), f32(3 * n, meta.angle_scale)];
  return meta;
}
function loadClip(i) {
  if (!pending.has(i)) {
    let resolve, reject;
    const promise = new Promise((res, rej) => { resolve = res; reject = rej; });
    pending.set(i, { promise, resolve, reject });
    const s = document.createElement('script');
    s.src = clips[i].file;
    s.onerror = () => { pending.delete(i); reject(new Error(`cannot load ${clips[i].file} (the page needs its clips/ folder next to it)`)); };
    document.head.appendChild(s);
  }
  return pending.get(i).promise;
}
let THREE = null;
async function loadThree() {
  if (!THREE) {
    const src = document.getElementById('three-src').textContent;
    THREE = await import(URL.createObjectURL(new Blob([src], { type: 'text/javascript' })));
  }
  return THREE;
}

// ---- the player ----------------------------------------------------------------------------
const player = { clip: null, meta: null, t: 0, playing: false, joint: 0, last: 0 };
let gfx = null;  // three.js objects, made once

function makeGraphics() {
  const view = $('view');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  view.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xffffff);
  const camera = new THREE.PerspectiveCamera(40, 1, 1, 100000);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 2.2));
  const grid = new THREE.GridHelper(2000, 40, 0xb8b8b8, 0xe2e2e2);  // 50 cm squares
  scene.add(grid);
  const labels = [document.createElement('div'), document.createElement('div')];
  labels[0].className = labels[1].className = 'label';
  labels[0].textContent = 'before'; labels[0].style.color = 'var(--before)';
  labels[1].textContent = 'after'; labels[1].style.color = 'var(--after)';
  for (const l of labels) view.appendChild(l);
  gfx = { renderer, scene, camera, grid, labels, skeletons: [], orbit: { yaw: 0.6, pitch: 0.25, dist: 450 }, target: new THREE.Vector3(), raycaster: new THREE.Raycaster() };
  // Orbit by dragging, zoom by the wheel; a click on a joint selects it.
  let drag = null;
  renderer.domElement.addEventListener('pointerdown', (e) => { drag = { x: e.clientX, y: e.clientY, moved: false }; });
  window.addEventListener('pointerup', (e) => { if (drag && !drag.moved) pickJoint(e); drag = null; });
  // The curves follow the joint under the cursor (and stay on it when the cursor leaves).
  renderer.domElement.addEventListener('pointermove', (e) => { if (!drag) pickJoint(e); });
  window.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
    gfx.orbit.yaw -= dx * 0.008;
    gfx.orbit.pitch = Math.max(-1.4, Math.min(1.4, gfx.orbit.pitch + dy * 0.008));
    drag.x = e.clientX; drag.y = e.clientY;
    draw();
  });
  renderer.domElement.addEventListener('wheel', (e) => { e.preventDefault(); gfx.orbit.dist *= Math.exp(e.deltaY * 0.001); draw(); }, { passive: false });
  new ResizeObserver(() => requestAnimationFrame(draw)).observe(view);
}

// One skeleton: a line per bone and a sphere per joint, positions set per frame.
function makeSkeleton(meta, color, onTop) {
  const J = meta.joints.length;
  const group = new THREE.Group();
  const bones = [];
  for (let j = 0; j < J; ++j) if (meta.parents[j] >= 0) bones.push([meta.parents[j], j]);
  const linePos = new Float32Array(bones.length * 6);
  const lineGeo = new THREE.BufferGeometry();
  lineGeo.setAttribute('position', new THREE.BufferAttribute(linePos, 3));
  // Overlaid, the skeleton drawn on top (before) shows where cleaning moved a bone.
  const lines = new THREE.LineSegments(lineGeo, new THREE.LineBasicMaterial({ color, depthTest: !onTop, transparent: onTop, opacity: onTop ? 0.85 : 1 }));
  lines.renderOrder = onTop ? 2 : 1;
  lines.frustumCulled = false;
  group.add(lines);
  const joints = new THREE.InstancedMesh(new THREE.SphereGeometry(1, 10, 8), new THREE.MeshLambertMaterial({ color }), J);
  joints.frustumCulled = false;
  group.add(joints);
  return { group, bones, linePos, lineGeo, joints, J };
}
function poseSkeleton(sk, pos, sample, radius, selected, garbage) {
  const base = sample * sk.J * 3;
  sk.bones.forEach(([a, b], k) => {
    for (let c = 0; c < 3; ++c) { sk.linePos[k * 6 + c] = pos[base + a * 3 + c]; sk.linePos[k * 6 + 3 + c] = pos[base + b * 3 + c]; }
  });
  sk.lineGeo.attributes.position.needsUpdate = true;
  const m = new THREE.Matrix4();
  for (let j = 0; j < sk.J; ++j) {
    const r = radius * (j === selected ? 2.6 : garbage.has(j) ? 0.6 : 1);
    m.makeScale(r, r, r).setPosition(pos[base + j * 3], pos[base + j * 3 + 1], pos[base + j * 3 + 2]);
    sk.joints.setMatrixAt(j, m);
  }
  sk.joints.instanceMatrix.needsUpdate = true;
}

async function openClip(i) {
  const c = clips[i];
  $('list').hidden = true;
  $('player').hidden = false;
  $('clip-name').textContent = c.name;
  renderDetails(c);
  if (!c.has_motion) { setStatus('error', `${c.name}: no motion on the page`); return; }
  setStatus('loading', `loading ${c.name}`);
  const [meta] = await Promise.all([loadClip(i), loadThree()]);
  if (!gfx) makeGraphics();
  for (const sk of gfx.skeletons) gfx.scene.remove(sk.group);
  const style = getComputedStyle(document.documentElement);
  gfx.skeletons = [makeSkeleton(meta, style.getPropertyValue('--before').trim(), true), makeSkeleton(meta, style.getPropertyValue('--after').trim(), false)];
  for (const sk of gfx.skeletons) gfx.scene.add(sk.group);
  // The floor: the lowest joint of the clip; the body's scale from its extent.
  let minY = Infinity, maxY = -Infinity;
  const pos = meta.pos[1];
  for (let k = 1; k < pos.length; k += 3) { minY = Math.min(minY, pos[k]); maxY = Math.max(maxY, pos[k]); }
  gfx.floor = minY;
  gfx.grid.position.y = minY;
  gfx.radius = Math.max(0.8, (maxY - minY) / 110);
  gfx.orbit.dist = Math.max(150, (maxY - minY) * 2.0);
  player.clip = c; player.meta = meta; player.t = 0; player.playing = false;
  meta.garbageSet = new Set(meta.garbage);
  meta.popFrames = meta.pops.map(([f]) => f);
  const sel = $('joint');
  sel.innerHTML = meta.joints.map((n, j) => `<option value="${j}">${esc(n)}${meta.garbageSet.has(j) ? ' (garbage)' : ''}</option>`).join('');
  // Start on the joint with the most pops, else the one cleaning moved most.
  const counts = new Map();
  for (const [, j] of meta.pops) counts.set(j, (counts.get(j) || 0) + 1);
  let joint = meta.joints.indexOf(c.change_max_joint);
  let best = 0;
  for (const [j, n] of counts) if (n > best) { best = n; joint = j; }
  player.joint = Math.max(0, joint);
  sel.value = String(player.joint);
  $('scrub').max = String(meta.frames - 1);
  // Every pop, by frame: a click goes there and shows its joint's curves.
  $('pop-list').innerHTML = meta.pops.length ? `<p><b>${meta.pops.length} pops ${c.pops_repaired ? 'repaired' : 'found'}</b> (frame, joint):<br>` +
    meta.pops.map(([f, j]) => `<a data-frame="${f}" data-joint="${j}">${f + 1} ${esc(meta.joints[j])}</a>`).join(' ') + '</p>' : '';
  $('play').innerHTML = '&#9654;';
  draw();
  setStatus('drawn', `drawn: ${c.name}, ${meta.count} samples of ${meta.frames} frames`, { clip: i, joints: meta.joints.length });
}

function renderDetails(c) {
  const row = (k, v) => (v === undefined || v === null || v === '') ? '' : `<dt>${esc(k)}</dt><dd>${v}</dd>`;
  $('details').innerHTML = [
    row('frames', `${c.frames} at ${fmt(c.fps, 0)} Hz (${fmt(c.seconds, 2)} s)`),
    row('joints', c.joints),
    row('units', esc(c.units) + ' (shown in cm)'),
    row('method', esc(c.method)),
    row('parameters', esc(c.parameters)),
    row('noise', c.noise_deg !== null && c.noise_deg !== undefined ? `${fmt(c.noise_deg, 3)}° (estimated)` : ''),
    row('pops', c.pops ? `${c.pops} ${c.pops_repaired ? 'repaired' : 'found'}: ${esc(c.pop_joints)}` : 'none'),
    row('garbage joints', c.garbage ? esc(c.garbage) : 'none'),
    row('foot contacts', `${c.contacts}${c.feet_locked ? ' (feet locked)' : ''}`),
    row('jitter', c.jitter_before !== undefined ? `${fmt(c.jitter_before, 0)} → ${fmt(c.jitter_after, 0)} cm/s² (${fmt(c.jitter_ratio, 2)}×)` : ''),
    row('skating', c.jitter_before !== undefined ? `${fmt(c.skating_before, 2)} → ${fmt(c.skating_after, 2)} cm/s` + (c.skating_ratio !== undefined ? ` (${fmt(c.skating_ratio, 2)}×)` : '') : ''),
    row('change', `${fmt(c.change_rms, 2)} cm RMS; at most ${fmt(c.change_max, 1)} cm (${esc(c.change_max_joint ?? '')}, frame ${c.change_max_frame + 1})`),
  ].join('') + '<p class="dim" style="grid-column: 1 / -1">Frames count from 1. Positions in cm; angles: the joint\'s local rotation as a rotation vector (axis × angle), x y z in degrees.</p>';
}

// The last sample at or before `frame` (samples: every stride-th frame, and the pops').
function sampleAt(frame) {
  const f = player.meta.sample_frames;
  let lo = 0, hi = f.length - 1;
  while (lo < hi) { const mid = (lo + hi + 1) >> 1; if (f[mid] <= frame) lo = mid; else hi = mid - 1; }
  return lo;
}
function frameOf(t) { const m = player.meta; return Math.min(m.frames - 1, Math.max(0, Math.floor(t * m.fps + 1e-6))); }

function draw() {
  if (!gfx || !player.meta) return;
  const m = player.meta;
  const frame = frameOf(player.t);
  const sample = sampleAt(frame);
  const show = [$('show-before').checked, $('show-after').checked];
  gfx.skeletons.forEach((sk, v) => poseSkeleton(sk, m.pos[v], sample, gfx.radius, player.joint, m.garbageSet));
  // Camera: orbit around the root (after cleaning), or around where the clip starts.
  const rootSample = $('follow').checked ? sample : 0;
  const p = m.pos[1];
  gfx.target.set(p[rootSample * m.joints.length * 3], p[rootSample * m.joints.length * 3 + 1], p[rootSample * m.joints.length * 3 + 2]);
  const o = gfx.orbit;
  gfx.camera.position.set(gfx.target.x + o.dist * Math.cos(o.pitch) * Math.sin(o.yaw), gfx.target.y + o.dist * Math.sin(o.pitch), gfx.target.z + o.dist * Math.cos(o.pitch) * Math.cos(o.yaw));
  gfx.camera.lookAt(gfx.target);
  const view = $('view'), w = view.clientWidth, h = view.clientHeight;
  const r = gfx.renderer;
  if (r.domElement.width !== Math.round(w * r.getPixelRatio()) || r.domElement.height !== Math.round(h * r.getPixelRatio())) r.setSize(w, h);
  const side = $('layout').value === 'side';
  r.setScissorTest(side);
  if (side) {
    gfx.camera.aspect = (w / 2) / h;
    gfx.camera.updateProjectionMatrix();
    for (let v = 0; v < 2; ++v) {
      gfx.skeletons[0].group.visible = v === 0 && show[0];
      gfx.skeletons[1].group.visible = v === 1 && show[1];
      r.setViewport(v * w / 2, 0, w / 2, h);
      r.setScissor(v * w / 2, 0, w / 2, h);
      r.render(gfx.scene, gfx.camera);
    }
  } else {
    gfx.camera.aspect = w / h;
    gfx.camera.updateProjectionMatrix();
    gfx.skeletons.forEach((sk, v) => { sk.group.visible = show[v]; });
    r.setViewport(0, 0, w, h);
    r.render(gfx.scene, gfx.camera);
  }
  gfx.labels[0].style.left = '8px';
  gfx.labels[1].style.left = side ? (w / 2 + 8) + 'px' : '80px';
  gfx.labels[0].hidden = !show[0];
  gfx.labels[1].hidden = !show[1];
  $('scrub').value = String(frame);
  $('time').textContent = `frame ${frame + 1} / ${m.frames} · ${(frame / m.fps).toFixed(2)} s · ${fmt(m.fps, 0)} Hz` + (m.stride > 1 ? ` (shown at ${fmt(m.fps / m.stride, 0)} Hz and at every pop)` : '');
  drawTimeline(frame);
  drawCurves(frame);
}

function canvas2d(el) {
  const dpr = window.devicePixelRatio || 1, w = el.clientWidth, h = el.clientHeight;
  if (el.width !== Math.round(w * dpr) || el.height !== Math.round(h * dpr)) { el.width = Math.round(w * dpr); el.height = Math.round(h * dpr); }
  const g = el.getContext('2d');
  g.setTransform(dpr, 0, 0, dpr, 0, 0);
  g.clearRect(0, 0, w, h);
  return { g, w, h };
}

// Timeline: a row per foot with its contacts, red ticks at the pops, the cursor.
function drawTimeline(frame) {
  const m = player.meta, { g, w, h } = canvas2d($('timeline'));
  const x = (f) => 6 + (w - 12) * f / Math.max(1, m.frames - 1);
  const rows = Math.max(1, m.contacts.length);
  const style = getComputedStyle(document.documentElement);
  g.font = '10px sans-serif';
  m.contacts.forEach((foot, k) => {
    const y = 4 + k * (h - 16) / rows, hh = (h - 16) / rows - 2;
    g.fillStyle = style.getPropertyValue('--contact');
    for (const [b, e] of foot.intervals) g.fillRect(x(b), y, Math.max(1, x(e - 1) - x(b)), hh);
    g.fillStyle = '#555';
    g.fillText(m.joints[foot.joint], 8, y + hh - 2);
  });
  g.fillStyle = style.getPropertyValue('--pop');
  for (const f of m.popFrames) g.fillRect(x(f) - 1, h - 12, 2, 12);
  g.fillStyle = '#000';
  g.fillRect(x(frame) - 1, 0, 2, h);
}

// The selected joint's rotation over the clip, before (dashed) and after (solid), in degrees.
function drawCurves(frame) {
  const m = player.meta, { g, w, h } = canvas2d($('curves'));
  const J = m.joints.length, j = player.joint;
  let lo = Infinity, hi = -Infinity;
  for (let v = 0; v < 2; ++v) for (let s = 0; s < m.count; ++s) for (let c = 0; c < 3; ++c) { const a = m.ang[v][(s * J + j) * 3 + c]; lo = Math.min(lo, a); hi = Math.max(hi, a); }
  if (hi - lo < 2) { const mid = (hi + lo) / 2; lo = mid - 1; hi = mid + 1; }
  const pad = (hi - lo) * 0.08; lo -= pad; hi += pad;
  const L = 44, R = 8, T = 16, B = 16;
  const x = (f) => L + (w - L - R) * f / Math.max(1, m.frames - 1);
  const y = (a) => T + (h - T - B) * (hi - a) / (hi - lo);
  g.font = '10px sans-serif';
  g.strokeStyle = '#eee'; g.fillStyle = '#666';
  const step = niceStep((hi - lo) / 4);
  for (let a = Math.ceil(lo / step) * step; a <= hi; a += step) { g.beginPath(); g.moveTo(L, y(a)); g.lineTo(w - R, y(a)); g.stroke(); g.fillText(`${+a.toFixed(2)}°`, 2, y(a) + 3); }
  const colors = ['#d62728', '#2ca02c', '#1f77b4'];
  for (let v = 0; v < 2; ++v) for (let c = 0; c < 3; ++c) {
    g.strokeStyle = colors[c]; g.globalAlpha = v === 0 ? 0.55 : 1; g.lineWidth = v === 0 ? 1 : 1.4;
    g.setLineDash(v === 0 ? [4, 3] : []);
    g.beginPath();
    for (let s = 0; s < m.count; ++s) { const px = x(m.sample_frames[s]), py = y(m.ang[v][(s * J + j) * 3 + c]); s ? g.lineTo(px, py) : g.moveTo(px, py); }
    g.stroke();
  }
  g.setLineDash([]); g.globalAlpha = 1; g.lineWidth = 1;
  g.fillStyle = getComputedStyle(document.documentElement).getPropertyValue('--pop');
  for (const [f, pj] of m.pops) if (pj === j) g.fillRect(x(f) - 1, T, 2, 6);
  g.fillStyle = '#000';
  g.fillRect(x(frame) - 0.5, T, 1, h - T - B);
  g.fillStyle = '#333';
  g.fillText(`${m.joints[j]}: rotation x (red) y (green) z (blue), degrees; dashed before, solid after; red marks: pops`, L, 11);
}
function niceStep(x) { const p = Math.pow(10, Math.floor(Math.log10(x))); const r = x / p; return (r < 1.5 ? 1 : r < 3.5 ? 2 : r < 7.5 ? 5 : 10) * p; }

function pickJoint(e) {
  if (!gfx || !player.meta) return;
  const rect = gfx.renderer.domElement.getBoundingClientRect();
  const side = $('layout').value === 'side';
  const w = side ? rect.width / 2 : rect.width;
  const lx = (e.clientX - rect.left) % w;
  if (e.clientX < rect.left || e.clientY < rect.top || e.clientY > rect.bottom) return;
  const ndc = new THREE.Vector2(lx / w * 2 - 1, -((e.clientY - rect.top) / rect.height) * 2 + 1);
  gfx.raycaster.setFromCamera(ndc, gfx.camera);
  const sk = gfx.skeletons[side && e.clientX - rect.left < w ? 0 : 1];
  sk.joints.computeBoundingSphere();
  const hits = gfx.raycaster.intersectObject(sk.joints);
  if (hits.length && hits[0].instanceId !== player.joint) { player.joint = hits[0].instanceId; $('joint').value = String(player.joint); draw(); }
}

function tick(now) {
  if (player.playing) {
    const dt = Math.min(0.25, (now - player.last) / 1000);
    player.t += dt * Number($('speed').value);
    const length = player.meta.frames / player.meta.fps;
    if (player.t >= length) player.t = 0;  // loop
    draw();
  }
  player.last = now;
  requestAnimationFrame(tick);
}
requestAnimationFrame(tick);

$('play').addEventListener('click', () => { player.playing = !player.playing; $('play').innerHTML = player.playing ? '&#10074;&#10074;' : '&#9654;'; });
$('scrub').addEventListener('input', () => { player.t = Number($('scrub').value) / player.meta.fps; draw(); });
$('joint').addEventListener('change', () => { player.joint = Number($('joint').value); draw(); });
for (const id of ['show-before', 'show-after', 'layout', 'follow']) $(id).addEventListener('input', draw);
$('back').addEventListener('click', () => { location.hash = ''; });
$('pop-list').addEventListener('click', (e) => {
  const a = e.target.closest('a');
  if (!a || !player.meta) return;
  player.playing = false;
  $('play').innerHTML = '&#9654;';
  player.t = Number(a.dataset.frame) / player.meta.fps;
  player.joint = Number(a.dataset.joint);
  $('joint').value = String(player.joint);
  draw();
});
function scrubTimeline(e) {
  if (!player.meta) return;
  const rect = $('timeline').getBoundingClientRect();
  const f = Math.round((e.clientX - rect.left - 6) / (rect.width - 12) * (player.meta.frames - 1));
  player.t = Math.min(player.meta.frames - 1, Math.max(0, f)) / player.meta.fps;
  draw();
}
$('timeline').addEventListener('pointerdown', (e) => { scrubTimeline(e); $('timeline').setPointerCapture(e.pointerId); });
$('timeline').addEventListener('pointermove', (e) => { if (e.buttons) scrubTimeline(e); });
window.addEventListener('keydown', (e) => {
  if ($('player').hidden || e.target.tagName === 'INPUT' && e.target.type === 'search') return;
  if (e.key === ' ') { e.preventDefault(); $('play').click(); }
  if (e.key === 'Escape') location.hash = '';
  if (e.key === 'ArrowRight' || e.key === 'ArrowLeft') {
    player.playing = false;
    player.t = Math.max(0, player.t + (e.key === 'ArrowRight' ? 1 : -1) / player.meta.fps);
    draw();
  }
});

// #clip=N opens clip N (links can be shared; the browser test opens one this way); &frame=F
// (from 1) and &layout=side|overlay set the view.
function route() {
  const m = /clip=(\d+)/.exec(location.hash);
  const layout = /layout=(overlay|side)/.exec(location.hash);
  if (layout) $('layout').value = layout[1];
  const frame = /frame=(\d+)/.exec(location.hash);
  if (m && clips[Number(m[1])]) {
    openClip(Number(m[1])).then(() => {
      if (frame && player.meta) { player.t = (Number(frame[1]) - 1) / player.meta.fps; draw(); }
    }).catch((e) => setStatus('error', 'error: ' + e.message));
  } else {
    player.playing = false;
    $('player').hidden = true;
    $('list').hidden = false;
  }
}
window.addEventListener('hashchange', route);
route();
