// rrslam viewer: the browser side of `rrslam-render html`.
//
// Bundled with three.js by esbuild into one script (package.json "build") that
// the C++ library embeds in every page; the page never loads anything else.
// It reads the JSON of <script type="application/json" id="rrslam-data">,
// written by stages/render/html/html_viewer.cc (the format is described in
// html_viewer.h), and draws:
//   - map points as THREE.Points, coloured by height (blue low -> red high);
//   - keyframes as small camera frusta (line segments) with an "up" tick on
//     the top edge, grey when they came from a loaded map;
//   - the keyframe trajectory (white), further trajectories (ground truth,
//     estimates) in a palette of their own, loop edges (yellow);
//   - a grid of 1 m cells on the floor plane, and an overlay with the map,
//     the producer, the counts, a legend with layer switches and the height
//     colour bar.
//
// Frames. Data are in the map's world frame (metres). The C++ side chooses
// a view frame (data.view_from_map, a rotation): x to the right, y up (the
// keyframes' mean up direction), z towards the initial eye (against the
// keyframes' mean viewing direction). All map geometry is in a group whose
// matrix is that rotation; the grid lies in the view frame's x-z plane.
//
// Initial view (documented so tests can predict the picture): the camera
// looks at the centre of the map's robust bounding box (points between the
// 2nd and 98th percentile on every view axis, and every keyframe centre) from
// the view direction (0, sin 30 deg, cos 30 deg), i.e. from behind the
// cameras and 30 degrees above, far enough for the box's bounding sphere to
// fit the narrower field of view. So view +x is screen right and view +y is
// screen up. R resets to it, T looks straight down, H hides the overlay
// (as the URL fragment #hide-panel does from the start).
//
// When the first frame is drawn, <html data-rrslam-viewer="ready"> is set
// ("error" when WebGL or the data fail; the overlay then says why) and
// window.rrslamViewer holds the scene, the camera and project(point_map).

import {
  BufferGeometry,
  Color,
  Float32BufferAttribute,
  GridHelper,
  Group,
  LineBasicMaterial,
  LineSegments,
  Matrix4,
  PerspectiveCamera,
  Points,
  PointsMaterial,
  SRGBColorSpace,
  Scene,
  Vector3,
  WebGLRenderer,
} from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { Line2 } from 'three/examples/jsm/lines/Line2.js';
import { LineGeometry } from 'three/examples/jsm/lines/LineGeometry.js';
import { LineMaterial } from 'three/examples/jsm/lines/LineMaterial.js';

const kBackground = 0x14171c;
const kKeyFrameColor = 0x4da3ff;
const kLoadedKeyFrameColor = 0x8a93a0;
const kKeyFrameTrajectoryColor = 0xf2f2f2;
const kLoopEdgeColor = 0xffd23f;
// Further trajectories, in order (no red: red is the top of the height scale).
const kTrajectoryPalette = [0x3ddc84, 0xff5fd2, 0x22d3ee, 0xffa94d, 0xb28dff];
// The height colours as CSS (HeightColor below), for the legend.
const kHeightGradient = 'linear-gradient(90deg, hsl(240,85%,55%), hsl(180,85%,55%), ' +
  'hsl(120,85%,55%), hsl(60,85%,55%), hsl(0,85%,55%))';
const kElevationDeg = 30;
const kFovDeg = 50;

// ---------------------------------------------------------------------------
// Data

function DecodeBase64(text) {
  if (!text) return new Uint8Array(0);
  const binary = atob(text);
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; ++i) bytes[i] = binary.charCodeAt(i);
  return bytes;
}

// Little-endian Float32 / Uint32 arrays (the C++ side writes them so; every
// browser's typed arrays are little-endian on the hardware that runs them).
function DecodeFloats(text) {
  return new Float32Array(DecodeBase64(text).buffer);
}
function DecodeUints(text) {
  return new Uint32Array(DecodeBase64(text).buffer);
}

function ReadData() {
  const element = document.getElementById('rrslam-data');
  if (!element) throw new Error('the page has no rrslam-data');
  const data = JSON.parse(element.textContent);
  if (data.format !== 'rrslam.viewer' || data.version !== 1) {
    throw new Error(`data format ${data.format} ${data.version}; this viewer reads rrslam.viewer 1`);
  }
  return data;
}

// ---------------------------------------------------------------------------
// Geometry helpers

// Value at fraction q in [0, 1] of ascending `sorted` (nearest rank).
function Percentile(sorted, q) {
  if (sorted.length === 0) return 0;
  const i = Math.min(sorted.length - 1, Math.max(0, Math.round(q * (sorted.length - 1))));
  return sorted[i];
}

// view = R * map for a row-major 3x3 R.
function Rotate(r, x, y, z, out) {
  out[0] = r[0] * x + r[1] * y + r[2] * z;
  out[1] = r[3] * x + r[4] * y + r[5] * z;
  out[2] = r[6] * x + r[7] * y + r[8] * z;
  return out;
}

// Blue (low) -> cyan -> green -> yellow -> red (high): hue 240 deg to 0, as
// CSS hsl(h, 85%, 55%) (sRGB; three.js keeps colours linear inside).
function HeightColor(t, color) {
  const clamped = Math.min(1, Math.max(0, t));
  return color.setHSL((2 / 3) * (1 - clamped), 0.85, 0.55, SRGBColorSpace);
}

// Keyframe centres and 3x3 rotations from 12 floats (row-major [R | t]) each.
function KeyFramePoses(floats) {
  const poses = [];
  for (let i = 0; i + 12 <= floats.length; i += 12) {
    poses.push({
      r: [floats[i], floats[i + 1], floats[i + 2], floats[i + 4], floats[i + 5], floats[i + 6],
        floats[i + 8], floats[i + 9], floats[i + 10]],
      t: [floats[i + 3], floats[i + 7], floats[i + 11]],
    });
  }
  return poses;
}

// The view-frame statistics that place the camera, the grid and the colours.
function SceneStats(points, poses, viewFromMap) {
  const v = [0, 0, 0];
  const axes = [[], [], []];
  for (let i = 0; i + 3 <= points.length; i += 3) {
    Rotate(viewFromMap, points[i], points[i + 1], points[i + 2], v);
    for (let a = 0; a < 3; ++a) axes[a].push(v[a]);
  }
  const heights = axes[1].slice().sort((a, b) => a - b);
  const low = new Vector3(Infinity, Infinity, Infinity);
  const high = new Vector3(-Infinity, -Infinity, -Infinity);
  for (let a = 0; a < 3; ++a) {
    if (axes[a].length === 0) continue;
    const sorted = a === 1 ? heights : axes[a].sort((x, y) => x - y);
    low.setComponent(a, Percentile(sorted, 0.02));
    high.setComponent(a, Percentile(sorted, 0.98));
  }
  for (const pose of poses) {
    Rotate(viewFromMap, pose.t[0], pose.t[1], pose.t[2], v);
    low.min(new Vector3(v[0], v[1], v[2]));
    high.max(new Vector3(v[0], v[1], v[2]));
  }
  if (!Number.isFinite(low.x)) {
    low.set(-1, -1, -1);
    high.set(1, 1, 1);
  }
  const centre = low.clone().add(high).multiplyScalar(0.5);
  const radius = Math.max(0.25, 0.5 * high.clone().sub(low).length());
  let heightLow = heights.length ? Percentile(heights, 0.02) : low.y;
  let heightHigh = heights.length ? Percentile(heights, 0.98) : high.y;
  if (!(heightHigh > heightLow)) heightHigh = heightLow + 1;
  return { centre, radius, floor: low.y, heightLow, heightHigh };
}

// ---------------------------------------------------------------------------
// Scene content

function MakePoints(points, viewFromMap, stats) {
  const colors = new Float32Array(points.length);
  const color = new Color();
  const span = stats.heightHigh - stats.heightLow;
  for (let i = 0; i + 3 <= points.length; i += 3) {
    const h = viewFromMap[3] * points[i] + viewFromMap[4] * points[i + 1] +
      viewFromMap[5] * points[i + 2];
    HeightColor((h - stats.heightLow) / span, color);
    colors[i] = color.r;
    colors[i + 1] = color.g;
    colors[i + 2] = color.b;
  }
  const geometry = new BufferGeometry();
  geometry.setAttribute('position', new Float32BufferAttribute(points, 3));
  geometry.setAttribute('color', new Float32BufferAttribute(colors, 3));
  const size = points.length / 3 > 5000 ? 2 : 3;
  const material = new PointsMaterial({ size, sizeAttenuation: false, vertexColors: true });
  return new Points(geometry, material);
}

// Frusta of depth `depth` metres: 4 rays, the image rectangle and a tick
// above the top edge (the camera's -y), as line segments.
function MakeFrusta(poses, loaded, camera, depth) {
  let { fx, fy, cx, cy, width, height } = camera;
  if (!(fx > 0 && fy > 0 && width > 0 && height > 0)) {
    width = 640;
    height = 480;
    fx = fy = 525;
    cx = 319.5;
    cy = 239.5;
  }
  const corners = [[0, 0], [width, 0], [width, height], [0, height]].map(
    ([u, vv]) => [((u - cx) / fx) * depth, ((vv - cy) / fy) * depth, depth]);
  const top = -(cy / fy) * depth;
  const tick = [[-0.25 * depth, top, depth], [0, top - 0.3 * depth, depth], [0.25 * depth, top, depth]];
  const segments = [];
  for (let c = 0; c < 4; ++c) segments.push([0, 0, 0], corners[c], corners[c], corners[(c + 1) % 4]);
  segments.push(tick[0], tick[1], tick[1], tick[2]);
  const positions = new Float32Array(poses.length * segments.length * 3);
  const colors = new Float32Array(positions.length);
  const kf = new Color(kKeyFrameColor);
  const old = new Color(kLoadedKeyFrameColor);
  const out = [0, 0, 0];
  let k = 0;
  poses.forEach((pose, i) => {
    const color = loaded && loaded[i] ? old : kf;
    for (const p of segments) {
      Rotate(pose.r, p[0], p[1], p[2], out);
      positions[k] = out[0] + pose.t[0];
      positions[k + 1] = out[1] + pose.t[1];
      positions[k + 2] = out[2] + pose.t[2];
      colors[k] = color.r;
      colors[k + 1] = color.g;
      colors[k + 2] = color.b;
      k += 3;
    }
  });
  const geometry = new BufferGeometry();
  geometry.setAttribute('position', new Float32BufferAttribute(positions, 3));
  geometry.setAttribute('color', new Float32BufferAttribute(colors, 3));
  return new LineSegments(geometry, new LineBasicMaterial({ vertexColors: true }));
}

// A polyline 2 px wide (WebGL lines are 1 px), or null with fewer than 2 points.
function MakeTrack(positions, color) {
  if (positions.length < 6) return null;
  const geometry = new LineGeometry();
  geometry.setPositions(positions);
  const material = new LineMaterial({ color, linewidth: 2 });
  return new Line2(geometry, material);
}

function MakeLoopEdges(edges, poses) {
  const positions = [];
  for (let i = 0; i + 2 <= edges.length; i += 2) {
    const a = poses[edges[i]];
    const b = poses[edges[i + 1]];
    if (a && b) positions.push(...a.t, ...b.t);
  }
  if (positions.length === 0) return null;
  const geometry = new BufferGeometry();
  geometry.setAttribute('position', new Float32BufferAttribute(positions, 3));
  return new LineSegments(geometry, new LineBasicMaterial({ color: kLoopEdgeColor }));
}

// ---------------------------------------------------------------------------
// Overlay

function Hex(color) {
  return '#' + color.toString(16).padStart(6, '0');
}

function Element(tag, className, text) {
  const e = document.createElement(tag);
  if (className) e.className = className;
  if (text !== undefined) e.textContent = text;
  return e;
}

function Metres(x) {
  return `${x.toFixed(2)} m`;
}

// Legend line with a switch: toggles `objects`' visibility, then redraws.
function LegendEntry(list, label, color, objects, redraw) {
  const row = Element('label', 'rr-entry');
  const box = Element('input');
  box.type = 'checkbox';
  box.checked = true;
  box.addEventListener('change', () => {
    for (const o of objects) o.visible = box.checked;
    redraw();
  });
  const swatch = Element('span', 'rr-swatch');
  swatch.style.background = color;
  row.append(box, swatch, Element('span', '', label));
  list.append(row);
}

// Hides or shows the overlay (key H; the URL fragment #hide-panel starts
// with it hidden, for clean pictures).
function TogglePanel() {
  document.documentElement.classList.toggle('rr-hide-panel');
}

function ShowError(message) {
  document.documentElement.dataset.rrslamViewer = 'error';
  const overlay = document.getElementById('rrslam-overlay');
  const line = Element('div', 'rr-error', `The 3D view is not available: ${message}`);
  if (overlay) overlay.append(line);
  else document.body.append(line);
}

// ---------------------------------------------------------------------------
// Viewer

function Main() {
  const data = ReadData();
  const viewFromMap = data.view_from_map;
  const points = DecodeFloats(data.points);
  const poses = KeyFramePoses(DecodeFloats(data.keyframe_poses));
  const loaded = data.keyframe_loaded ? DecodeBase64(data.keyframe_loaded) : null;
  const stats = SceneStats(points, poses, viewFromMap);

  const renderer = new WebGLRenderer({ antialias: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setSize(window.innerWidth, window.innerHeight);
  renderer.setClearColor(kBackground);
  renderer.domElement.id = 'rrslam-canvas';
  document.body.prepend(renderer.domElement);

  const scene = new Scene();
  const root = new Group();  // Map frame.
  const m = viewFromMap;
  root.matrix.set(m[0], m[1], m[2], 0, m[3], m[4], m[5], 0, m[6], m[7], m[8], 0, 0, 0, 0, 1);
  root.matrixAutoUpdate = false;
  scene.add(root);

  const layers = [];  // [label, colour, objects]
  const cloud = MakePoints(points, viewFromMap, stats);
  root.add(cloud);
  layers.push([`map points (${data.counts.points})`, kHeightGradient, [cloud]]);

  const frustumDepth = Math.min(0.5, Math.max(0.02, 0.04 * stats.radius));
  if (poses.length > 0) {
    const frusta = MakeFrusta(poses, loaded, data.camera, frustumDepth);
    root.add(frusta);
    const fromLoadedMap = data.counts.loaded_keyframes;
    const label = fromLoadedMap > 0
      ? `keyframes (${data.counts.keyframes}; ${fromLoadedMap} of the loaded map, grey)`
      : `keyframes (${data.counts.keyframes})`;
    layers.push([label, Hex(kKeyFrameColor), [frusta]]);
  }
  const keyframeTrack = MakeTrack(DecodeFloats(data.keyframe_trajectory), kKeyFrameTrajectoryColor);
  if (keyframeTrack) {
    root.add(keyframeTrack);
    layers.push(['keyframe trajectory', Hex(kKeyFrameTrajectoryColor), [keyframeTrack]]);
  }
  const loops = MakeLoopEdges(DecodeUints(data.loop_edges), poses);
  if (loops) {
    root.add(loops);
    layers.push([`loop edges (${data.counts.loop_edges})`, Hex(kLoopEdgeColor), [loops]]);
  }
  (data.trajectories || []).forEach((trajectory, i) => {
    const color = kTrajectoryPalette[i % kTrajectoryPalette.length];
    const track = MakeTrack(DecodeFloats(trajectory.positions), color);
    if (!track) return;
    root.add(track);
    layers.push([`${trajectory.name} (${trajectory.poses} poses)`, Hex(color), [track]]);
  });

  // Floor grid, 1 m cells, lines on whole metres of the view frame.
  const gridSize = 2 * Math.ceil(stats.radius + 1);
  const grid = new GridHelper(gridSize, gridSize, 0x59606b, 0x2e333b);
  grid.position.set(Math.round(stats.centre.x), stats.floor, Math.round(stats.centre.z));
  scene.add(grid);
  layers.push(['floor grid, 1 m cells', '#59606b', [grid]]);

  const camera = new PerspectiveCamera(kFovDeg, window.innerWidth / window.innerHeight, 0.01, 100);
  const controls = new OrbitControls(camera, renderer.domElement);
  controls.screenSpacePanning = true;
  controls.zoomToCursor = true;

  const render = () => renderer.render(scene, camera);
  const distance = () => {
    const vertical = (kFovDeg * Math.PI) / 180;
    const horizontal = 2 * Math.atan(Math.tan(vertical / 2) * camera.aspect);
    return (1.05 * stats.radius) / Math.sin(Math.min(vertical, horizontal) / 2);
  };
  const lookFrom = (direction) => {
    const d = distance();
    camera.near = Math.max(1e-3, 0.002 * stats.radius);
    camera.far = 50 * (d + stats.radius);
    camera.position.copy(stats.centre).addScaledVector(direction.normalize(), d);
    camera.updateProjectionMatrix();
    controls.target.copy(stats.centre);
    controls.maxDistance = 20 * d;
    controls.update();
    render();
  };
  const elevation = (kElevationDeg * Math.PI) / 180;
  const resetView = () => lookFrom(new Vector3(0, Math.sin(elevation), Math.cos(elevation)));
  const topView = () => lookFrom(new Vector3(0, 1, 1e-4));
  controls.addEventListener('change', render);

  window.addEventListener('resize', () => {
    camera.aspect = window.innerWidth / window.innerHeight;
    camera.updateProjectionMatrix();
    renderer.setSize(window.innerWidth, window.innerHeight);
    render();
  });
  window.addEventListener('keydown', (event) => {
    if (event.target instanceof HTMLInputElement && event.target.type !== 'checkbox') return;
    const material = cloud.material;
    if (event.key === 'r' || event.key === 'R') resetView();
    else if (event.key === 't' || event.key === 'T') topView();
    else if (event.key === 'h' || event.key === 'H') TogglePanel();
    else if (event.key === '+' || event.key === '=') material.size = Math.min(12, material.size + 1);
    else if (event.key === '-') material.size = Math.max(1, material.size - 1);
    else return;
    render();
  });

  BuildOverlay(data, stats, layers, render);
  if (window.location.hash.slice(1).split(/[&,]/).includes('hide-panel')) TogglePanel();
  resetView();

  const project = (p) => {
    const v = new Vector3(p[0], p[1], p[2]).applyMatrix4(root.matrix).project(camera);
    return { x: ((v.x + 1) / 2) * window.innerWidth, y: ((1 - v.y) / 2) * window.innerHeight };
  };
  window.rrslamViewer = {
    data,
    scene,
    root,
    camera,
    controls,
    renderer,
    stats,
    viewFromMap: new Matrix4().copy(root.matrix),
    project,  // Map-frame point -> CSS pixels of the window (x right, y down).
    resetView,
    topView,
    render,
  };
  document.documentElement.dataset.rrslamViewer = 'ready';
}

function BuildOverlay(data, stats, layers, redraw) {
  const overlay = document.getElementById('rrslam-overlay');
  const legend = Element('div', 'rr-legend');
  for (const [label, color, objects] of layers) LegendEntry(legend, label, color, objects, redraw);
  const bar = Element('div', 'rr-colorbar');
  const gradient = Element('span', 'rr-gradient');
  gradient.style.background = kHeightGradient;
  const floor = stats.floor;
  bar.append(
    Element('span', '', Metres(stats.heightLow - floor)),
    gradient,
    Element('span', '', Metres(stats.heightHigh - floor)),
  );
  const help = Element('div', 'rr-help',
    'drag: orbit · right-drag: pan · wheel: zoom · R: reset view · T: top view · ' +
    '+/−: point size · H: hide this panel');
  overlay.append(legend, Element('div', 'rr-caption', 'point height above the floor grid'), bar, help);
}

try {
  Main();
} catch (error) {
  ShowError(error && error.message ? error.message : String(error));
}
