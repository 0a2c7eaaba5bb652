// The review page's 3D view (autorig.show.viewer): one WebGL view, opened on any card's rig. It draws the mesh
// with its skeleton over it, turns and zooms (OrbitControls), colours the mesh by the weights of a picked joint,
// moves the rig (every bone bent in turn, computed here from the skeleton), and places markers: the reviewer picks
// a name and clicks the surface; the points are given back in the input file's own coordinates.
(() => {
'use strict';
const T = window.THREE;
const views = JSON.parse(document.getElementById('views').textContent);
const $ = id => document.getElementById(id);
const dialog = $('viewer'), canvas = $('view-canvas'), status = $('view-status'), title = $('view-title');
const jointMenu = $('view-joint'), markerMenu = $('view-marker'), moveButton = $('view-move');
const motionMenu = $('view-motion');
const list = $('view-markers'), saveButton = $('view-download'), clearButton = $('view-clear');
const folderInput = $('view-folder'), folderBox = $('view-folder-box'), markerBox = $('view-marker-box');
const MESH = 0x8fa8c8, BONE = 0xff7f00, MARKER = 0xff00ff;
const BEND = 0.7, BEAT = 0.9;              // radians at most, seconds per bone
const CLICK_PIXELS = 5;                    // a press that moves less than this is a click, not a turn
const buttons = document.querySelectorAll('button.view3d');
if (!T || !T.GLTFLoader) {
  for (const b of buttons) { b.disabled = true; b.title = 'the three.js file beside this page is missing'; }
  return;
}
let renderer = null, scene, camera, controls, model = null, skinned = [], bones = [], movers = [];
let boneLines = null, jointPoints = null, markerGroup = null, markerRadius = 0.01;
let view = null, frame = null, placed = {}, moving = false, start = 0, loop = 0, token = 0, track = null;
const folder = new Map();                  // a chosen output folder's files, by path inside it
const material = new T.MeshLambertMaterial({color: MESH, side: T.DoubleSide});

function setup() {
  renderer = new T.WebGLRenderer({canvas, antialias: true, preserveDrawingBuffer: true});
  renderer.setPixelRatio(1);
  scene = new T.Scene();
  scene.background = new T.Color(0x1d2127);
  scene.add(new T.HemisphereLight(0xffffff, 0x444450, 2.2));
  camera = new T.PerspectiveCamera(35, 1, 0.01, 100);
  const light = new T.DirectionalLight(0xffffff, 1.6);
  light.position.set(0.3, 0.5, 1);
  camera.add(light);
  scene.add(camera);
  controls = new T.OrbitControls(camera, canvas);
  controls.addEventListener('change', draw);
  let down = null;
  canvas.addEventListener('pointerdown', e => { down = [e.clientX, e.clientY]; });
  canvas.addEventListener('pointerup', e => {
    if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < CLICK_PIXELS) place(e);
    down = null;
  });
}

function setState(state, text) {
  dialog.dataset.state = state;
  status.textContent = text || '';
}

function bytesOf(base64) {
  const text = atob(base64), bytes = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
  return bytes.buffer;
}

// The rig's bytes: inlined in the page, else the file beside it (fetch: over http), else from a chosen folder.
async function rigBytes(v) {
  if (v.inline) return bytesOf(document.getElementById(v.inline).textContent.trim());
  // The folder chosen may be the output folder or one above it.
  const file = folder.get(v.output) || Array.from(folder).find(([path]) => path.endsWith('/' + v.output))?.[1];
  if (file) return file.arrayBuffer();
  try {
    const answer = await fetch(v.href);
    if (answer.ok) return answer.arrayBuffer();
  } catch (e) { /* a page opened from disk may not read files beside it: ask for the folder */ }
  folderBox.hidden = false;
  throw new Error('this browser does not let a page opened from disk read ' + v.output +
                  ': choose the output folder (the one holding it) below');
}

async function open(index) {
  const mine = ++token;
  view = views[index];
  frame = view.frame || [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  placed = Object.assign({}, view.given || {});
  title.textContent = view.name;
  if (!dialog.open) dialog.showModal();
  if (!renderer) setup();
  stop();
  clearModel();
  folderBox.hidden = true;
  setState('loading', 'reading ' + view.output + ' ...');
  try {
    const bytes = await rigBytes(view);
    const gltf = await new T.GLTFLoader().parseAsync(bytes, '');
    if (mine !== token) return;
    show(gltf.scene);
    setState('ready', '');
  } catch (e) {
    if (mine === token) setState('error', String(e.message || e));
  }
}

function clearModel() {
  if (!model) return;
  scene.remove(model, boneLines, jointPoints, markerGroup);
  model.traverse(o => { if (o.geometry) o.geometry.dispose(); });
  for (const o of [boneLines, jointPoints]) { o.geometry.dispose(); o.material.dispose(); }
  model = null; skinned = []; bones = []; movers = [];
}

function show(root) {
  // The file's coordinates, turned so that the rig's up is the view's up and its front faces the camera.
  model = new T.Group();
  const [x, y, z] = frame;
  model.matrixAutoUpdate = false;
  model.matrix.set(x[0], x[1], x[2], 0, y[0], y[1], y[2], 0, z[0], z[1], z[2], 0, 0, 0, 0, 1);
  model.add(root);
  scene.add(model);
  root.traverse(o => {
    if (o.isMesh) {
      o.material = material;
      o.frustumCulled = false;           // a moving skinned mesh leaves its rest bounds
      if (o.isSkinnedMesh) skinned.push(o);
    }
  });
  model.updateMatrixWorld(true);
  bones = skinned.length ? skinned[0].skeleton.bones : [];
  for (const b of bones) { b.userData.rest = b.quaternion.clone(); b.userData.at = b.position.clone(); }
  const box = new T.Box3();
  for (const m of skinned) {
    m.geometry.computeBoundingBox();
    box.union(m.geometry.boundingBox.clone().applyMatrix4(m.matrixWorld));
  }
  for (const b of bones) box.expandByPoint(b.getWorldPosition(new T.Vector3()));
  const size = box.getSize(new T.Vector3()), centre = box.getCenter(new T.Vector3());
  const span = Math.max(size.x, size.y, size.z) || 1;
  markerRadius = 0.012 * span;
  camera.near = span / 100; camera.far = span * 100;
  // From the front for an upright shape (a biped: left and right apart), from its left and a little ahead for
  // a long one (a four-legged animal: its legs apart); far enough for the whole bounding sphere.
  const turn = size.z > 1.2 * size.x ? Math.PI / 3 : 0;
  const distance = 1.05 * box.getBoundingSphere(new T.Sphere()).radius / Math.sin(T.MathUtils.degToRad(camera.fov / 2));
  camera.position.copy(centre).add(new T.Vector3(Math.sin(turn), 0.12, Math.cos(turn)).normalize().multiplyScalar(distance));
  controls.target.copy(centre);
  camera.updateProjectionMatrix();
  controls.update();
  movers = bendable();
  track = view.motion ? decoded(view.motion) : null;
  motionMenu.replaceChildren(new Option('every bone in turn', ''),
                             ...(track ? [new Option(view.motion.name + ' (in place)', 'bvh')] : []));
  motionMenu.value = track ? 'bvh' : '';
  boneLines = new T.LineSegments(new T.BufferGeometry(),
    new T.LineBasicMaterial({color: BONE, depthTest: false, transparent: true}));
  jointPoints = new T.Points(new T.BufferGeometry(),
    new T.PointsMaterial({color: BONE, size: 7, sizeAttenuation: false, depthTest: false, transparent: true}));
  boneLines.renderOrder = jointPoints.renderOrder = 2;
  markerGroup = new T.Group();
  markerGroup.renderOrder = 3;
  scene.add(boneLines, jointPoints, markerGroup);
  fillMenus();
  resize();
  pose(0);
  drawMarkers();
}

// Bones that can bend: each joint with a child joint below a parent joint. The bend's axis is the rig's left
// (forward and back, as knees, spines and tails bend), or its front for a bone along the left (arms in a T).
function bendable() {
  const left = new T.Vector3(1, 0, 0), front = new T.Vector3(0, 0, 1), result = [];
  for (const b of bones) {
    const child = b.children.find(c => c.isBone);
    if (!child || !(b.parent && b.parent.isBone)) continue;
    const from = b.getWorldPosition(new T.Vector3()), along = child.getWorldPosition(new T.Vector3()).sub(from);
    if (along.lengthSq() === 0) continue;
    along.normalize();
    let axis = left.clone().addScaledVector(along, -left.dot(along));
    if (axis.length() < 0.3) axis = front.clone().addScaledVector(along, -front.dot(along));
    // The axis in the bone's own rest frame: its rotation is applied after the bone's rest rotation.
    const world = b.getWorldQuaternion(new T.Quaternion());
    result.push({bone: b, axis: axis.normalize().applyQuaternion(world.invert())});
  }
  return result;
}

// A BVH motion retargeted in Python (autorig.show.viewer.motion_track): each frame's local rotations of the
// joints it turns, and the root's position.
function decoded(m) {
  const byName = new Map(bones.map(b => [b.name, b]));
  const named = n => byName.get(n) || byName.get(T.PropertyBinding.sanitizeNodeName(n)) || null;
  return {fps: m.fps, frames: m.frames, bones: m.joints.map(named), root: named(m.root),
          rotations: new Float32Array(bytesOf(m.rotations)), translations: new Float32Array(bytesOf(m.translations))};
}

function pose(seconds) {
  for (const b of bones) { b.quaternion.copy(b.userData.rest); b.position.copy(b.userData.at); }
  if (moving && track && motionMenu.value === 'bvh') {
    const f = Math.floor(seconds * track.fps) % track.frames, count = track.bones.length;
    track.bones.forEach((b, k) => { if (b) b.quaternion.fromArray(track.rotations, 4 * (f * count + k)); });
    if (track.root) track.root.position.fromArray(track.translations, 3 * f);
  } else if (moving && movers.length) {
    const beat = seconds / BEAT, m = movers[Math.floor(beat) % movers.length];
    const bend = new T.Quaternion().setFromAxisAngle(m.axis, BEND * Math.sin(Math.PI * (beat % 1)));
    m.bone.quaternion.multiply(bend);
  }
  model.updateMatrixWorld(true);
  const lines = [], points = [];
  const p = new T.Vector3(), q = new T.Vector3();
  for (const b of bones) {
    b.getWorldPosition(p);
    points.push(p.x, p.y, p.z);
    if (b.parent && b.parent.isBone) {
      b.parent.getWorldPosition(q);
      lines.push(q.x, q.y, q.z, p.x, p.y, p.z);
    }
  }
  boneLines.geometry.setAttribute('position', new T.Float32BufferAttribute(lines, 3));
  jointPoints.geometry.setAttribute('position', new T.Float32BufferAttribute(points, 3));
  draw();
}

function draw() {
  if (renderer && model) renderer.render(scene, camera);
}

function resize() {
  const width = canvas.clientWidth || 800, height = canvas.clientHeight || 600;
  renderer.setSize(width, height, false);
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
}

function tick(now) {
  if (!moving) return;
  pose(Math.max(0, now - start) / 1000);
  loop = requestAnimationFrame(tick);
}

function stop() {
  moving = false;
  cancelAnimationFrame(loop);
  moveButton.textContent = 'move';
}

moveButton.addEventListener('click', () => {
  if (!model) return;
  if (moving) { stop(); pose(0); return; }
  moving = true;
  moveButton.textContent = 'stop';
  start = performance.now();
  loop = requestAnimationFrame(tick);
});

// The weights of one joint as colours: none grey-blue, then blue, green, yellow and red at full weight.
function showWeights() {
  const name = jointMenu.value;
  for (const m of skinned) {
    const g = m.geometry, index = m.skeleton.bones.findIndex(b => b.name === name);
    if (!name || index < 0) { g.deleteAttribute('color'); continue; }
    const joints = g.getAttribute('skinIndex'), weights = g.getAttribute('skinWeight');
    const colours = new Float32Array(joints.count * 3), colour = new T.Color();
    for (let v = 0; v < joints.count; v++) {
      let w = 0;
      for (let k = 0; k < 4; k++) if (joints.getComponent(v, k) === index) w += weights.getComponent(v, k);
      if (w <= 0) colour.setHex(MESH); else colour.setHSL(0.66 * (1 - Math.min(w, 1)), 0.9, 0.5);
      colours.set([colour.r, colour.g, colour.b], 3 * v);
    }
    g.setAttribute('color', new T.BufferAttribute(colours, 3));
  }
  material.vertexColors = Boolean(name);
  material.color.setHex(name ? 0xffffff : MESH);
  material.needsUpdate = true;
  draw();
}
jointMenu.addEventListener('change', showWeights);
motionMenu.addEventListener('change', () => { start = performance.now(); if (!moving) draw(); });

function fillMenus() {
  const names = bones.map(b => b.name);
  jointMenu.replaceChildren(new Option('none (plain mesh)', ''), ...names.map(n => new Option(n, n)));
  material.vertexColors = false;
  material.color.setHex(MESH);
  material.needsUpdate = true;
  markerBox.hidden = !view.template;
  const set = view.markers || [];
  const others = (view.joints || names).filter(n => !set.includes(n) && !n.endsWith('_end'));
  const groups = [];
  if (set.length) {
    const g = document.createElement('optgroup');
    g.label = 'the ' + view.template + ' markers';
    g.dataset.set = 'yes';
    g.append(...set.map(n => new Option(n, n)));
    groups.push(g);
  }
  const g = document.createElement('optgroup');
  g.label = set.length ? 'other joints' : 'joints';
  g.append(...others.map(n => new Option(n, n)));
  groups.push(g);
  markerMenu.replaceChildren(new Option('(pick a marker, then click the surface)', ''), ...groups);
  nextMarker();
}

function nextMarker() {
  const free = Array.from(markerMenu.options).find(o => o.value && !(o.value in placed) &&
                                                       o.parentElement.dataset.set === 'yes');
  markerMenu.value = free ? free.value : '';
}

// A click on the surface: where the ray meets the mesh (at rest), in the view's frame, then in the file's.
function place(event) {
  const name = markerMenu.value;
  if (!model || !name || markerBox.hidden) return;
  if (moving) { stop(); pose(0); }
  const box = canvas.getBoundingClientRect();
  const ndc = new T.Vector2(((event.clientX - box.left) / box.width) * 2 - 1,
                            -((event.clientY - box.top) / box.height) * 2 + 1);
  const ray = new T.Raycaster();
  ray.setFromCamera(ndc, camera);
  const hits = ray.intersectObjects(skinned, false);
  if (!hits.length) { status.textContent = 'no surface under the click: click on the mesh'; return; }
  // A joint (a wrist, a knee, a paw) lies inside the limb: halfway between where the ray enters it and where
  // it leaves it. A landmark (the chin, the groin, the withers) is the point on the surface.
  const exit = hits.find(h => h.distance > hits[0].distance + 1e-3 * markerRadius);
  const inside = !(view.surface || []).includes(name) && exit !== undefined;
  const point = inside ? hits[0].point.clone().lerp(exit.point, 0.5) : hits[0].point;
  placed[name] = toInput(point);
  status.textContent = name + ' placed ' + (inside ? 'inside the limb under the click' : 'on the surface');
  drawMarkers();
  nextMarker();
}

// view = frame . input (frame's rows: the file's directions of the view's x, y, z), so input = frame^T . view.
function toInput(p) {
  const [x, y, z] = frame;
  return [0, 1, 2].map(i => x[i] * p.x + y[i] * p.y + z[i] * p.z);
}

function toView(q) {
  return new T.Vector3(...frame.map(r => r[0] * q[0] + r[1] * q[1] + r[2] * q[2]));
}

function drawMarkers() {
  if (!markerGroup) return;
  for (const m of markerGroup.children) m.geometry.dispose();
  markerGroup.clear();
  const sphere = new T.SphereGeometry(markerRadius, 12, 8);
  const look = new T.MeshBasicMaterial({color: MARKER, depthTest: false, transparent: true});
  list.replaceChildren();
  for (const [name, point] of Object.entries(placed)) {
    const dot = new T.Mesh(sphere, look);
    dot.position.copy(toView(point));
    dot.renderOrder = 3;
    markerGroup.add(dot);
    const item = document.createElement('li'), remove = document.createElement('button');
    item.textContent = name + ' ' + point.map(c => c.toPrecision(5)).join(', ') + ' ';
    remove.textContent = 'remove';
    remove.type = 'button';
    remove.addEventListener('click', () => { delete placed[name]; drawMarkers(); nextMarker(); });
    item.append(remove);
    list.append(item);
  }
  saveButton.disabled = !Object.keys(placed).length;
  saveButton.textContent = 'download ' + view.markers_file;
  draw();
}

function markersText() {
  const order = (view.markers || []).filter(n => n in placed);
  const names = order.concat(Object.keys(placed).filter(n => !order.includes(n)));
  // One marker a line: {"chin": [x, y, z], ...}, 9 significant digits (the mesh's float32 holds fewer).
  const lines = names.map(n => ' ' + JSON.stringify(n) + ': ' +
                          JSON.stringify(placed[n].map(c => Number(c.toPrecision(9)))).replaceAll(',', ', '));
  return '{\n' + lines.join(',\n') + '\n}\n';
}

saveButton.addEventListener('click', () => {
  const link = document.createElement('a');
  link.href = URL.createObjectURL(new Blob([markersText()], {type: 'application/json'}));
  link.download = view.markers_file;
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(link.href), 60000);
  status.textContent = 'save ' + view.markers_file + ' beside ' + view.name + ', then run the batch again';
});
clearButton.addEventListener('click', () => { placed = {}; drawMarkers(); nextMarker(); });

folderInput.addEventListener('change', () => {
  for (const file of folderInput.files) {
    // webkitRelativePath starts with the chosen folder's own name.
    folder.set(file.webkitRelativePath.split('/').slice(1).join('/'), file);
  }
  if (view) open(views.indexOf(view));
});

$('view-close').addEventListener('click', () => dialog.close());
dialog.addEventListener('close', stop);
window.addEventListener('resize', () => { if (renderer && dialog.open) { resize(); draw(); } });
for (const b of buttons) b.addEventListener('click', () => open(Number(b.dataset.view)));
// For scripts that drive the page (the tests do): the open rig's markers file, a view point in the input's
// coordinates, and where an input point is drawn (client pixels).
window.autorigViewer = {
  views, markersText, toInput: p => toInput(new T.Vector3(...p)),
  screenOf(q) {
    const p = toView(q).project(camera), box = canvas.getBoundingClientRect();
    return [box.left + (p.x + 1) / 2 * box.width, box.top + (1 - p.y) / 2 * box.height];
  },
};
})();
