// tac3d viewer: one panel per sensor (SN), fed live by the server's /ws stream (`tac3d run
// --web`), or, under `tac3d view`, by a recording's frames fetched by index with the time
// slider; and a friction map's mesh (docs/viewer.md).
'use strict';

const HISTORY = 300;             // samples in the scrolling plots
const BACKGROUND = 0x101214;
const sensors = new Map();       // sn -> panel
const views = [];                // other 3D views (the friction map)
let received = 0;
let socket = null;
let replay = null;               // under `tac3d view`: /api/frames (count, t, F, M)

function fmt3(v) { return v.map(x => (x === null ? '-' : x.toFixed(3))).join(', '); }

// Blue (no load) -> green -> yellow -> red (the largest normal force seen).
function heat(t, color) {
  t = Math.min(1, Math.max(0, t));
  const r = Math.min(1, Math.max(0, 1.5 * t * 2 - 1.0));
  const g = Math.min(1, Math.max(0, t < 0.5 ? 2 * t : 2 - 2 * t + 0.3));
  const b = Math.min(1, Math.max(0, 1 - 2 * t));
  color.setRGB(r, g, b);
}

function makePlot(canvas, labels) {
  return { canvas, labels, series: labels.map(() => []) };
}

function pushPlot(plot, values) {
  plot.series.forEach((s, k) => { s.push(values[k]); if (s.length > HISTORY) s.shift(); });
}

// Live: the last HISTORY samples, newest at the right. Replay: the whole recording, with the
// slider's frame (plot.cursor) marked.
function drawPlot(plot, unit) {
  const ctx = plot.canvas.getContext('2d');
  const w = plot.canvas.width, h = plot.canvas.height;
  ctx.fillStyle = '#101214';
  ctx.fillRect(0, 0, w, h);
  let lim = 1e-3;
  plot.series.forEach(s => s.forEach(v => { if (v !== null) lim = Math.max(lim, Math.abs(v)); }));
  lim *= 1.1;
  ctx.strokeStyle = '#444';
  ctx.beginPath(); ctx.moveTo(0, h / 2); ctx.lineTo(w, h / 2); ctx.stroke();
  const colors = ['#f66', '#6d6', '#69f'];
  const span = replay ? Math.max(1, replay.count - 1) : HISTORY;
  const xOf = (i, n) => w - (n - 1 - i) * (w / span);
  plot.series.forEach((s, k) => {
    ctx.strokeStyle = colors[k];
    ctx.beginPath();
    s.forEach((v, i) => {
      const x = xOf(i, s.length);
      const y = h / 2 - (v === null ? 0 : v) / lim * (h / 2 - 4);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.stroke();
    ctx.fillStyle = colors[k];
    ctx.fillText(plot.labels[k], 6 + 34 * k, 12);
  });
  if (plot.cursor !== undefined) {
    const x = xOf(plot.cursor, plot.series[0].length);
    ctx.strokeStyle = '#ddd';
    ctx.beginPath(); ctx.moveTo(x, 0); ctx.lineTo(x, h); ctx.stroke();
  }
  ctx.fillStyle = '#aaa';
  ctx.fillText('\u00b1' + lim.toPrecision(3) + ' ' + unit, w - 90, 12);
}

// A three.js renderer, scene, camera and orbit controls in the element `view`.
function makeView(view, id) {
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setSize(view.clientWidth, view.clientHeight);
  renderer.setClearColor(BACKGROUND);
  renderer.domElement.id = id;
  view.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(40, view.clientWidth / view.clientHeight, 0.1, 1000);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  return { renderer, scene, camera, controls };
}

// Looks at a bounding sphere from below-front, z up.
function placeCamera(panel, sphere) {
  panel.controls.target.copy(sphere.center);
  panel.camera.position.set(sphere.center.x - 0.2 * sphere.radius, sphere.center.y - 2.0 * sphere.radius,
                            sphere.center.z + 1.6 * sphere.radius);
  panel.camera.up.set(0, 0, 1);
  panel.controls.update();
}

function makePanel(sn, rows, cols) {
  const node = document.getElementById('sensor-template').content.firstElementChild.cloneNode(true);
  document.getElementById('sensors').appendChild(node);
  const $ = cls => node.querySelector('.' + cls);
  $('sn').textContent = sn;
  const n = rows * cols;
  const view = $('view3d');
  const { renderer, scene, camera, controls } = makeView(view, 'canvas3d-' + sn);
  // Where the first sensor's 3D view is, for the headless test's screenshot check.
  if (!document.body.dataset.canvas) {
    const r = view.getBoundingClientRect();
    document.body.dataset.canvas = JSON.stringify([r.left, r.top, r.width, r.height]);
  }
  $('zero-one').onclick = () => { if (socket && socket.readyState === 1) socket.send('zero ' + sn); };
  $('zero-one').hidden = replay !== null;  // a recording's frames were computed when recorded

  // The surface: one vertex a marker, two triangles a grid cell whose four markers are valid.
  const surface = new THREE.BufferGeometry();
  surface.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * n), 3));
  surface.setAttribute('color', new THREE.BufferAttribute(new Float32Array(3 * n), 3));
  const mesh = new THREE.Mesh(surface, new THREE.MeshBasicMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide }));
  scene.add(mesh);
  const wire = new THREE.LineSegments(new THREE.WireframeGeometry(surface), new THREE.LineBasicMaterial({ color: 0x000000, transparent: true, opacity: 0.25 }));
  // Tangential force arrows: a shaft and two barbs per marker.
  const arrows = new THREE.BufferGeometry();
  arrows.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * 6 * n), 3));
  scene.add(new THREE.LineSegments(arrows, new THREE.LineBasicMaterial({ color: 0xffffff })));
  // The contact region: the markers in contact as points.
  const contact = new THREE.BufferGeometry();
  contact.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * n), 3));
  scene.add(new THREE.Points(contact, new THREE.PointsMaterial({ color: 0xff40ff, size: 0.6 })));
  scene.add(new THREE.AxesHelper(5));

  const panel = {
    node, $, rows, cols, renderer, scene, camera, controls, surface, arrows, contact, wire,
    placed: false, maxNormal: 0.02, maxTangential: 0.02, validKey: '',
    forcePlot: makePlot($('force-plot'), ['Fx', 'Fy', 'Fz']),
    momentPlot: makePlot($('moment-plot'), ['Mx', 'My', 'Mz']),
  };
  // The surface's colour scale: heat() from no load to the panel's current largest normal force.
  const bar = $('colour-scale'), ctx = bar.getContext('2d');
  const swatch = new THREE.Color();
  for (let x = 0; x < bar.width; ++x) {
    heat(x / (bar.width - 1), swatch);
    ctx.fillStyle = '#' + swatch.getHexString();
    ctx.fillRect(x, 0, 1, bar.height);
  }
  sensors.set(sn, panel);
  return panel;
}

function updateIndex(panel, valid) {
  const key = valid;
  if (key === panel.validKey) return;
  panel.validKey = key;
  const idx = [];
  const { rows, cols } = panel;
  const ok = i => valid[i] === '1';
  for (let r = 0; r + 1 < rows; ++r) {
    for (let c = 0; c + 1 < cols; ++c) {
      const a = r * cols + c, b = a + 1, d = a + cols, e = d + 1;
      if (ok(a) && ok(b) && ok(d) && ok(e)) idx.push(a, b, e, a, e, d);
    }
  }
  panel.surface.setIndex(idx);
}

function onFrame(m) {
  const panel = sensors.get(m.sn) || makePanel(m.sn, m.rows, m.cols);
  const n = m.rows * m.cols;
  const pos = panel.surface.attributes.position.array;
  const col = panel.surface.attributes.color.array;
  const arrow = panel.arrows.attributes.position.array;
  const cpos = panel.contact.attributes.position.array;
  const color = new THREE.Color();
  let maxNormal = 0, maxTangential = 0, ncontact = 0, nvalid = 0;
  const normal = new Float64Array(n), tangential = new Float64Array(3 * n);
  for (let i = 0; i < n; ++i) {
    if (m.valid[i] !== '1') continue;
    ++nvalid;
    for (let k = 0; k < 3; ++k) pos[3 * i + k] = m.p[3 * i + k];
    const f = [m.f[3 * i], m.f[3 * i + 1], m.f[3 * i + 2]];
    const nn = [m.n[3 * i], m.n[3 * i + 1], m.n[3 * i + 2]];
    const fn = f[0] * nn[0] + f[1] * nn[1] + f[2] * nn[2];
    normal[i] = Math.max(0, -fn);  // a press pushes against the outward normal
    for (let k = 0; k < 3; ++k) tangential[3 * i + k] = f[k] - fn * nn[k];
    maxNormal = Math.max(maxNormal, normal[i]);
    maxTangential = Math.max(maxTangential, Math.hypot(tangential[3 * i], tangential[3 * i + 1], tangential[3 * i + 2]));
  }
  // Scales that grow at once and shrink slowly, so colours do not flicker.
  panel.maxNormal = Math.max(0.05, maxNormal, 0.995 * panel.maxNormal);
  panel.maxTangential = Math.max(0.05, maxTangential, 0.995 * panel.maxTangential);
  const arrowScale = 3.0 / panel.maxTangential;  // mm per N: the largest arrow is 3 mm
  arrow.fill(0);
  cpos.fill(0);
  let ci = 0;
  for (let i = 0; i < n; ++i) {
    if (m.valid[i] !== '1') { color.setRGB(0.3, 0.3, 0.3); col.set([color.r, color.g, color.b], 3 * i); continue; }
    heat(normal[i] / panel.maxNormal, color);
    col[3 * i] = color.r; col[3 * i + 1] = color.g; col[3 * i + 2] = color.b;
    const p = [pos[3 * i], pos[3 * i + 1], pos[3 * i + 2] + 0.05];
    const t = [tangential[3 * i] * arrowScale, tangential[3 * i + 1] * arrowScale, tangential[3 * i + 2] * arrowScale];
    const len = Math.hypot(t[0], t[1], t[2]);
    if (len > 0.15) {
      const tip = [p[0] + t[0], p[1] + t[1], p[2] + t[2]];
      // Barbs: back from the tip, 25% of the length, rotated +-30 deg about the normal (z).
      const bx = -t[0] * 0.25, by = -t[1] * 0.25;
      const c30 = Math.cos(0.5), s30 = Math.sin(0.5);
      const seg = [p, tip, tip, [tip[0] + c30 * bx - s30 * by, tip[1] + s30 * bx + c30 * by, tip[2]],
                   tip, [tip[0] + c30 * bx + s30 * by, tip[1] - s30 * bx + c30 * by, tip[2]]];
      seg.forEach((v, j) => arrow.set(v, 18 * i + 3 * j));
    }
    if (m.contact[i] === '1') { cpos.set([p[0], p[1], p[2] + 0.05], 3 * ci); ++ci; ++ncontact; }
  }
  panel.contact.setDrawRange(0, ci);
  updateIndex(panel, m.valid);
  panel.surface.attributes.position.needsUpdate = true;
  panel.surface.attributes.color.needsUpdate = true;
  panel.arrows.attributes.position.needsUpdate = true;
  panel.contact.attributes.position.needsUpdate = true;
  panel.surface.computeBoundingSphere();
  if (!panel.placed && nvalid > 0) {
    placeCamera(panel, panel.surface.boundingSphere);
    panel.placed = true;
  }
  const $ = panel.$;
  $('index').textContent = m.index;
  // Replaying, the rate the frames were recorded at; live, the server's measured rate.
  const fps = replay ? replay.rate : m.fps;
  $('fps').textContent = (replay ? 'recorded at ' : '') + (fps === null ? '-' : fps.toFixed(1));
  $('colour-max').textContent = panel.maxNormal.toFixed(3);
  $('slip').textContent = m.slip;
  $('mu').textContent = m.mu === null ? '' : '\u03bc = ' + m.mu.toFixed(3) + (m.mu_sigma === null ? '' : ' \u00b1 ' + m.mu_sigma.toFixed(3));
  $('margin-text').textContent = m.slip_margin === null ? '-' :
    m.slip_margin.toFixed(2) + (m.slip_margin_sigma === null ? '' : ' \u00b1 ' + m.slip_margin_sigma.toFixed(2)) +
    (m.least_normal_force_n === null ? '' : ', hold with ' + m.least_normal_force_n.toFixed(2) + ' N');
  $('flags').textContent = (m.flags || 'none') + (m.init < 100 ? ' (' + m.init + '%)' : '');
  $('ncontact').textContent = ncontact;
  $('nvalid').textContent = nvalid;
  $('force').textContent = fmt3(m.F);
  $('moment').textContent = fmt3(m.M);
  if (replay) {
    panel.forcePlot.series = [0, 1, 2].map(k => replay.F.map(v => v[k]));
    panel.momentPlot.series = [0, 1, 2].map(k => replay.M.map(v => v[k]));
    panel.forcePlot.cursor = panel.momentPlot.cursor = m.index_in_view;
  } else {
    pushPlot(panel.forcePlot, m.F);
    pushPlot(panel.momentPlot, m.M);
  }
  drawPlot(panel.forcePlot, 'N');
  drawPlot(panel.momentPlot, 'N mm');
  panel.renderer.render(panel.scene, panel.camera);
}

function onImage(m) {
  const panel = sensors.get(m.sn);
  if (!panel) return;
  const camera = panel.$('camera');
  // Where the first camera image is, once shown, for the headless test's marker check.
  camera.onload = () => {
    if (document.body.dataset.camera) return;
    const r = camera.getBoundingClientRect();
    document.body.dataset.camera = JSON.stringify([r.left, r.top, r.width, r.height]);
  };
  camera.src = 'data:image/jpeg;base64,' + m.jpeg;
}

function connect() {
  socket = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws');
  const state = document.getElementById('connection');
  socket.onopen = () => { state.textContent = 'connected'; state.className = 'good'; };
  socket.onclose = () => {
    state.textContent = 'disconnected, retrying'; state.className = 'bad';
    setTimeout(connect, 1000);
  };
  socket.onmessage = event => {
    const m = JSON.parse(event.data);
    if (m.type === 'frame') {
      ++received;
      document.getElementById('received').textContent = received;
      document.title = 'tac3d viewer: ' + received + ' frames';
      onFrame(m);
    } else if (m.type === 'image') {
      onImage(m);
    }
  };
}

// `tac3d view`: frame i of the recording, fetched when the slider moves (one request at a
// time; the slider's latest value is fetched when it is done).
let loading = false;
async function showFrame() {
  if (loading) return;
  loading = true;
  const slider = document.getElementById('slider');
  let i;
  do {
    i = Number(slider.value);
    document.getElementById('slider-label').textContent =
      'frame ' + (i + 1) + ' / ' + replay.count + ', t = ' + replay.t[i].toFixed(3) + ' s';
    const frame = await fetch('api/frame/' + i);
    if (frame.ok) {
      const m = await frame.json();
      m.index_in_view = i;
      ++received;
      document.getElementById('received').textContent = received;
      onFrame(m);
    }
    const image = await fetch('api/image/' + i);
    if (image.ok) onImage(await image.json());
  } while (Number(slider.value) !== i);
  document.body.dataset.shown = i;  // for the headless test
  loading = false;
}

async function startReplay() {
  const r = await fetch('api/frames');
  if (!r.ok) return;
  replay = await r.json();
  if (replay.count === 0) return;
  const span = replay.t[replay.count - 1] - replay.t[0];
  replay.rate = replay.count > 1 && span > 0 ? (replay.count - 1) / span : null;
  document.getElementById('mode').textContent = 'recording';
  document.getElementById('replay').hidden = false;
  document.getElementById('zero').hidden = true;
  const slider = document.getElementById('slider');
  slider.max = replay.count - 1;
  slider.oninput = showFrame;
  document.title = 'tac3d view: ' + replay.count + ' frames';
  showFrame();
}

// Each triangle split into its three corners' regions (corner, edge midpoints, centroid), each
// region flat in its corner's band colour: every point shows its nearest vertex's band, as the
// map's PNG does, and colours of different bands are never blended.
function bandRegions(map) {
  const v = map.vertices, c = map.colors, t = map.triangles;
  const position = [], color = [], at = i => [v[3 * i], v[3 * i + 1], v[3 * i + 2]];
  const mid = (p, q) => p.map((x, k) => (x + q[k]) / 2);
  for (let f = 0; f < t.length; f += 3) {
    const p = [at(t[f]), at(t[f + 1]), at(t[f + 2])];
    const g = p[0].map((x, k) => (x + p[1][k] + p[2][k]) / 3);
    for (let j = 0; j < 3; ++j) {
      const a = p[j], ab = mid(a, p[(j + 1) % 3]), ca = mid(a, p[(j + 2) % 3]);
      position.push(...a, ...ab, ...g, ...a, ...g, ...ca);
      const rgb = [0, 1, 2].map(k => c[3 * t[f + j] + k] / 255);
      for (let n = 0; n < 6; ++n) color.push(...rgb);
    }
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(position), 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(color), 3));
  geometry.computeVertexNormals();
  geometry.computeBoundingSphere();
  return geometry;
}

// `tac3d view --friction-map`: the mesh in the paper's bands (the server's colours).
async function showFrictionMap() {
  const r = await fetch('api/friction-map');
  if (!r.ok) return;
  const map = await r.json();
  const section = document.getElementById('friction');
  section.hidden = false;
  if (!replay) document.getElementById('mode').textContent = 'friction map';
  document.getElementById('friction-path').textContent = map.path;
  const panel = makeView(document.getElementById('friction-view'), 'canvas3d-friction');
  const geometry = bandRegions(map);
  panel.scene.add(new THREE.Mesh(geometry, new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide })));
  panel.scene.add(new THREE.AmbientLight(0xffffff, 0.45));
  const light = new THREE.DirectionalLight(0xffffff, 0.6);
  light.position.set(0, -1, 2);
  panel.scene.add(light);
  placeCamera(panel, geometry.boundingSphere);
  const swatch = (rgb, text) => '<span class="swatch" style="background:rgb(' + rgb + ')"></span>' + text + '<br>';
  document.getElementById('friction-legend').innerHTML =
    swatch('40,90,255', '\u03bc \u2264 0.5: ' + map.bands.low + ' vertices') +
    swatch('40,200,60', '0.5 < \u03bc \u2264 0.8: ' + map.bands.medium) +
    swatch('230,40,40', '\u03bc > 0.8: ' + map.bands.high) +
    swatch('150,150,150', 'unknown: ' + map.bands.unknown);
  views.push(panel);
}

document.getElementById('zero').onclick = () => { if (socket && socket.readyState === 1) socket.send('zero'); };
function animate() {
  requestAnimationFrame(animate);
  // Where the friction map's view is now (the sensors' panels above it come later), for the
  // headless test's screenshot check.
  const friction = document.getElementById('canvas3d-friction');
  if (friction) {
    const r = friction.getBoundingClientRect();
    document.body.dataset.frictionCanvas = JSON.stringify([r.left, r.top, r.width, r.height]);
  }
  [...sensors.values(), ...views].forEach(p => { p.controls.update(); p.renderer.render(p.scene, p.camera); });
}
connect();
startReplay();
showFrictionMap();
animate();
