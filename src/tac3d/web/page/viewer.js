// tac3d live viewer: one panel per sensor (SN), fed by the server's /ws stream (docs/viewer.md).
'use strict';

const HISTORY = 300;             // samples in the scrolling plots
const BACKGROUND = 0x101214;
const sensors = new Map();       // sn -> panel
let received = 0;
let socket = null;

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
  plot.series.forEach((s, k) => {
    ctx.strokeStyle = colors[k];
    ctx.beginPath();
    s.forEach((v, i) => {
      const x = w - (s.length - 1 - i) * (w / HISTORY);
      const y = h / 2 - (v === null ? 0 : v) / lim * (h / 2 - 4);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.stroke();
    ctx.fillStyle = colors[k];
    ctx.fillText(plot.labels[k], 6 + 34 * k, 12);
  });
  ctx.fillStyle = '#aaa';
  ctx.fillText('\u00b1' + lim.toPrecision(3) + ' ' + unit, w - 90, 12);
}

function makePanel(sn, rows, cols) {
  const node = document.getElementById('sensor-template').content.firstElementChild.cloneNode(true);
  document.getElementById('sensors').appendChild(node);
  const $ = cls => node.querySelector('.' + cls);
  $('sn').textContent = sn;
  const n = rows * cols;
  const view = $('view3d');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setSize(view.clientWidth, view.clientHeight);
  renderer.setClearColor(BACKGROUND);
  renderer.domElement.id = 'canvas3d-' + sn;
  view.appendChild(renderer.domElement);
  // Where the first sensor's 3D view is, for the headless test's screenshot check.
  if (!document.body.dataset.canvas) {
    const r = view.getBoundingClientRect();
    document.body.dataset.canvas = JSON.stringify([r.left, r.top, r.width, r.height]);
  }
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(40, view.clientWidth / view.clientHeight, 0.1, 1000);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);

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
    const s = panel.surface.boundingSphere;
    panel.controls.target.copy(s.center);
    panel.camera.position.set(s.center.x - 0.2 * s.radius, s.center.y - 2.0 * s.radius, s.center.z + 1.6 * s.radius);
    panel.camera.up.set(0, 0, 1);
    panel.controls.update();
    panel.placed = true;
  }
  const $ = panel.$;
  $('index').textContent = m.index;
  $('fps').textContent = m.fps === null ? '-' : m.fps.toFixed(1);
  $('slip').textContent = m.slip;
  $('mu').textContent = m.mu === null ? '' : '\u03bc = ' + m.mu.toFixed(3) + (m.mu_sigma === null ? '' : ' \u00b1 ' + m.mu_sigma.toFixed(3));
  $('flags').textContent = (m.flags || 'none') + (m.init < 100 ? ' (' + m.init + '%)' : '');
  $('ncontact').textContent = ncontact;
  $('nvalid').textContent = nvalid;
  $('force').textContent = fmt3(m.F);
  $('moment').textContent = fmt3(m.M);
  pushPlot(panel.forcePlot, m.F);
  pushPlot(panel.momentPlot, m.M);
  drawPlot(panel.forcePlot, 'N');
  drawPlot(panel.momentPlot, 'N mm');
  panel.renderer.render(panel.scene, panel.camera);
}

function onImage(m) {
  const panel = sensors.get(m.sn);
  if (panel) panel.$('camera').src = 'data:image/jpeg;base64,' + m.jpeg;
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

document.getElementById('zero').onclick = () => { if (socket && socket.readyState === 1) socket.send('zero'); };
function animate() {
  requestAnimationFrame(animate);
  sensors.forEach(p => { p.controls.update(); p.renderer.render(p.scene, p.camera); });
}
connect();
animate();
