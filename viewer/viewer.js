// kinolab's 3D viewer: draws a kinolab scene (docs/viewer.md) with three.js: the world's
// obstacles, per query the planners' trajectories, search trees and flights replayed with the
// known map growing, each planner in its colour of the report's figures, a tree's edge states
// in the figures' colours. Orbit, pan, zoom, and a toggle per layer. `window.kinolabViewer` is
// the page's handle for scripts and tests.
(function () {
  "use strict";
  const BACKGROUND = 0xf4f6f8;
  // Planners' colours, as the report's (kinolab_analysis.plots.PALETTE and planner_colours;
  // tests keep them equal) for a scene that brings none: none black or grey (the start's and
  // the goal's), none an edge state's.
  const PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
                   "#17becf", "#000080", "#bcbd22", "#637939", "#a6761d", "#01665e", "#f99379",
                   "#dd1c77", "#393b79", "#1b9e77", "#800000", "#e6ab02", "#b3446c"];
  const START_COLOUR = "#000000";
  const GOAL_COLOUR = "#6c757d";
  // A tree's edge states in the colours of the report's search-tree figure (the paper's
  // Fig. 6; kinolab_analysis.data.EDGE_COLOURS, tests keep them equal): lazy's cheap partial
  // edges translucent, rejected ones dashed.
  const EDGE_STATES = {
    partial: {colour: "#f4a261", opacity: 0.35},
    full: {colour: "#2a9d8f", opacity: 0.8},
    certified: {colour: "#264653", opacity: 1},
    rejected: {colour: "#e63946", opacity: 1, dashed: true},
  };
  // At most this many edges of one state are drawn, evenly chosen: tens of thousands of lazy
  // partial edges would haze over the trajectory. The legend says how many there are.
  const MAX_EDGES = 3000;

  const scene = JSON.parse(document.getElementById("kinolab-scene").textContent);
  document.getElementById("title").textContent = scene.title || "kinolab";
  document.title = (scene.title || "kinolab") + " (3D)";

  const container = document.getElementById("view");
  const renderer = new THREE.WebGLRenderer({antialias: true, preserveDrawingBuffer: true});
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(BACKGROUND);
  container.appendChild(renderer.domElement);
  const world3d = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(45, 1, 0.05, 5000);
  camera.up.set(0, 0, 1);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  controls.screenSpacePanning = true;
  world3d.add(new THREE.AmbientLight(0xffffff, 0.55));
  const sun = new THREE.DirectionalLight(0xffffff, 0.6);
  sun.position.set(0.4, -0.6, 1.0);
  world3d.add(sun);

  // Each planner's colour: the scene's (a report's), else its palette slot, FNV-1a of its
  // name, the later of two on one slot (in name order) taking the next free one.
  const plannerColour = Object.assign({}, scene.colours || {});
  (function assignColours() {
    const names = new Set();
    for (const query of scene.queries || []) {
      for (const item of [...query.trajectories, ...query.trees, ...query.flights]) names.add(item.planner);
    }
    const taken = new Set(Object.values(plannerColour));
    for (const name of [...names].sort()) {
      if (name in plannerColour) continue;
      let hash = 0x811c9dc5;
      for (const byte of new TextEncoder().encode(name)) hash = Math.imul(hash ^ byte, 16777619) >>> 0;
      let slot = hash % PALETTE.length;
      for (let step = 0; step < PALETTE.length && taken.has(PALETTE[slot]); ++step) slot = (slot + 1) % PALETTE.length;
      plannerColour[name] = PALETTE[slot];
      taken.add(PALETTE[slot]);
    }
  })();
  function colourOf(planner) { return plannerColour[planner]; }

  // A state's segments (flat point pairs; an edge's segments follow one another) as at most
  // MAX_EDGES edges, evenly chosen: a segment that starts where the one before ended continues
  // its edge.
  function thinned(flat) {
    const edges = [];
    for (let i = 0; i + 5 < flat.length; i += 6) {
      const continues = i > 0 && flat[i] === flat[i - 3] && flat[i + 1] === flat[i - 2] && flat[i + 2] === flat[i - 1];
      if (!continues) edges.push([]);
      edges[edges.length - 1].push(i);
    }
    if (edges.length <= MAX_EDGES) return {points: flat, drawn: edges.length, total: edges.length};
    const points = [];
    for (let k = 0; k < MAX_EDGES; ++k) {
      for (const i of edges[Math.floor(k * edges.length / MAX_EDGES)]) points.push(...flat.slice(i, i + 6));
    }
    return {points: points, drawn: MAX_EDGES, total: edges.length};
  }

  function vectors(flat) {
    const points = [];
    for (let i = 0; i + 2 < flat.length; i += 3) points.push(new THREE.Vector3(flat[i], flat[i + 1], flat[i + 2]));
    return points;
  }

  // Unit boxes scaled and moved per instance: one draw call for every obstacle.
  // Obstacles above this plane are cut away (the "cut above" slider), to look into buildings.
  const cut = new THREE.Plane(new THREE.Vector3(0, 0, -1), 1e9);
  renderer.localClippingEnabled = true;
  function boxes(count, colour, opacity) {
    const material = new THREE.MeshLambertMaterial({color: colour, transparent: opacity < 1, opacity: opacity,
                                                    clippingPlanes: [cut]});
    const mesh = new THREE.InstancedMesh(new THREE.BoxBufferGeometry(1, 1, 1), material, Math.max(count, 1));
    mesh.count = count;
    mesh.frustumCulled = false;  // its bounds are the unit box's, not the instances'
    return mesh;
  }
  const matrix = new THREE.Matrix4();
  function placeBox(mesh, index, min, max) {
    matrix.makeScale(max[0] - min[0], max[1] - min[1], max[2] - min[2]);
    matrix.setPosition((min[0] + max[0]) / 2, (min[1] + max[1]) / 2, (min[2] + max[2]) / 2);
    mesh.setMatrixAt(index, matrix);
  }

  // ---- layers: a group each, with a checkbox -------------------------------------------
  const layers = {};  // id -> {group, input}
  const layersDiv = document.getElementById("layers");
  function heading(text) {
    const h = document.createElement("h2");
    h.textContent = text;
    layersDiv.appendChild(h);
  }
  function addLayer(id, label, colour, group, visible) {
    const base = id;
    for (let n = 2; id in layers; ++n) id = base + "-" + n;  // two layers of one name
    group.visible = visible;
    world3d.add(group);
    const row = document.createElement("label");
    const input = document.createElement("input");
    input.type = "checkbox";
    input.id = "layer-" + id;
    input.checked = visible;
    input.addEventListener("change", () => { group.visible = input.checked; render(); });
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = colour;
    row.append(input, swatch, document.createTextNode(label));
    layersDiv.appendChild(row);
    layers[id] = {group: group, input: input};
  }

  // ---- the world ------------------------------------------------------------------------
  let worldCentre = new THREE.Vector3();
  let worldSize = 10;
  if (scene.world) {
    const w = scene.world;
    const r = w.resolution;
    const o = w.origin;
    const count = w.boxes.length / 6;
    const mesh = boxes(count, "#8d99ae", 1);
    for (let i = 0; i < count; ++i) {
      const b = w.boxes.slice(6 * i, 6 * i + 6);
      placeBox(mesh, i, [o[0] + b[0] * r, o[1] + b[1] * r, o[2] + b[2] * r],
                        [o[0] + b[3] * r, o[1] + b[4] * r, o[2] + b[5] * r]);
    }
    mesh.instanceMatrix.needsUpdate = true;
    const group = new THREE.Group();
    group.add(mesh);
    const size = [w.dims[0] * r, w.dims[1] * r, w.dims[2] * r];
    const floor = new THREE.Mesh(new THREE.PlaneBufferGeometry(size[0], size[1]),
                                 new THREE.MeshBasicMaterial({color: 0xe6e9ed, side: THREE.DoubleSide}));
    floor.position.set(o[0] + size[0] / 2, o[1] + size[1] / 2, o[2] - 0.001);
    const outline = new THREE.LineSegments(
        new THREE.EdgesGeometry(new THREE.BoxBufferGeometry(size[0], size[1], size[2])),
        new THREE.LineBasicMaterial({color: 0x9aa5b1}));
    outline.position.set(o[0] + size[0] / 2, o[1] + size[1] / 2, o[2] + size[2] / 2);
    world3d.add(floor, outline);
    heading("World: " + w.name);
    addLayer("obstacles", "obstacles" + (w.stride > 1 ? " (every " + w.stride + " voxels)" : ""),
             "#8d99ae", group, true);
    const row = document.createElement("label");
    const slider = document.createElement("input");
    slider.type = "range";
    slider.id = "cut";
    slider.min = o[2];
    slider.max = o[2] + size[2];
    slider.step = r;
    slider.value = slider.max;
    const label = document.createElement("span");
    const showCut = () => {
      const z = Number(slider.value);
      const none = z >= o[2] + size[2] - r / 2;  // the top, give or take the slider's rounding
      cut.constant = none ? 1e9 : z;
      label.textContent = none ? "cut above: none" : "cut above " + z.toFixed(2) + " m";
      render();
    };
    slider.addEventListener("input", showCut);
    row.append(label, document.createElement("br"), slider);
    layersDiv.appendChild(row);
    label.textContent = "cut above: none";
    worldCentre = new THREE.Vector3(o[0] + size[0] / 2, o[1] + size[1] / 2, o[2] + size[2] / 2);
    worldSize = Math.max(size[0], size[1], size[2]);
  }

  // ---- queries: every layer of each, shown for the selected query -----------------------
  const querySelect = document.getElementById("query");
  const queryGroups = [];
  const flights = [];  // {query, line, vehicle, known, t, points, cells}
  let maxFlightTime = 0;
  (scene.queries || []).forEach((query, index) => {
    const option = document.createElement("option");
    option.value = index;
    option.textContent = query.name;
    querySelect.appendChild(option);
    const layerGroups = [];
    const markers = new THREE.Group();
    // Black ball, grey diamond: colours and shapes no planner has.
    const startMarker = new THREE.Mesh(new THREE.SphereBufferGeometry(0.25, 16, 12),
                                       new THREE.MeshLambertMaterial({color: START_COLOUR}));
    startMarker.position.fromArray(query.start);
    const goalMarker = new THREE.Mesh(new THREE.OctahedronBufferGeometry(0.35),
                                      new THREE.MeshLambertMaterial({color: GOAL_COLOUR}));
    goalMarker.position.fromArray(query.goal);
    for (const marker of [startMarker, goalMarker]) {
      // Over trees and obstacles, like the trajectories (three.js draws transparent objects
      // after opaque ones, in renderOrder: "transparent" puts these last).
      Object.assign(marker.material, {depthTest: false, transparent: true});
      marker.renderOrder = 11;
    }
    markers.add(startMarker, goalMarker);
    layerGroups.push(["q" + index + "-markers", "start (black ball) and goal (grey diamond)",
                      START_COLOUR, markers]);
    // A trajectory identical to an earlier one (lazy's and eager's, at equal cost) lies exactly
    // under it: the legend says so, since toggling it changes no pixel.
    const firstWith = {};
    for (const trajectory of query.trajectories) {
      const group = new THREE.Group();
      const points = vectors(trajectory.points);
      if (points.length >= 2) {
        const curve = new THREE.CatmullRomCurve3(points, false, "catmullrom", 0);
        // Drawn over the trees and obstacles, so that no tree buries it.
        const tube = new THREE.Mesh(new THREE.TubeBufferGeometry(curve, Math.min(4 * points.length, 2000), 0.08, 8, false),
                                    new THREE.MeshLambertMaterial({color: colourOf(trajectory.planner), depthTest: false, transparent: true}));
        tube.renderOrder = 10;
        group.add(tube);
      }
      const key = trajectory.points.join(",");
      const same = key in firstWith ? " (the same as " + firstWith[key] + "'s)" : "";
      if (!(key in firstWith)) firstWith[key] = trajectory.planner;
      layerGroups.push(["q" + index + "-trajectory-" + trajectory.planner,
                        trajectory.planner + ": trajectory" + same, colourOf(trajectory.planner), group]);
    }
    // A tree is shown at first only when one planner has the view to itself: several trees
    // (tens of thousands of segments each) would bury each other and every trajectory.
    const planners = new Set([...query.trajectories, ...query.trees, ...query.flights].map((x) => x.planner));
    for (const tree of query.trees) {
      for (const state of Object.keys(EDGE_STATES)) {
        const flat = tree.edges[state] || [];
        if (!flat.length) continue;
        const look = EDGE_STATES[state];
        const {points, drawn, total} = thinned(flat);
        const geometry = new THREE.BufferGeometry();
        geometry.setAttribute("position", new THREE.Float32BufferAttribute(points, 3));
        const material = look.dashed
            ? new THREE.LineDashedMaterial({color: look.colour, dashSize: 0.08, gapSize: 0.06})
            : new THREE.LineBasicMaterial({color: look.colour, transparent: look.opacity < 1, opacity: look.opacity});
        const lines = new THREE.LineSegments(geometry, material);
        if (look.dashed) lines.computeLineDistances();
        const group = new THREE.Group();
        group.add(lines);
        const count = drawn < total ? drawn.toLocaleString("en") + " of " + total.toLocaleString("en") + " drawn"
                                    : total.toLocaleString("en");
        layerGroups.push(["q" + index + "-tree-" + tree.planner + "-" + state,
                          tree.planner + ": " + state + " edges (" + count + (look.dashed ? ", dashed" : "") + ")",
                          look.colour, group, planners.size === 1]);
      }
    }
    for (const flight of query.flights) {
      const colour = colourOf(flight.planner);
      const group = new THREE.Group();
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute("position", new THREE.Float32BufferAttribute(flight.points, 3));
      const line = new THREE.Line(geometry, new THREE.LineBasicMaterial({color: colour}));
      const vehicle = new THREE.Mesh(new THREE.SphereBufferGeometry(0.25, 16, 12),
                                     new THREE.MeshLambertMaterial({color: colour}));
      group.add(line, vehicle);
      layerGroups.push(["q" + index + "-flight-" + flight.planner, flight.planner + ": flight", colour, group]);
      let known = null;
      let cells = [];
      if (flight.known) {
        // Each voxel of the final known map (x, y, z, first known occupied), in time order.
        const k = flight.known;
        const half = k.size / 2;
        for (let i = 0; i + 3 < k.points.length; i += 4) {
          cells.push([k.points[i], k.points[i + 1], k.points[i + 2], k.points[i + 3]]);
        }
        cells.sort((a, b) => a[3] - b[3]);
        // The known obstacles in a pale tint of the planner's colour: its path stands out.
        const tint = new THREE.Color(colour).lerp(new THREE.Color(0xffffff), 0.55).getStyle();
        known = boxes(cells.length, tint, 0.6);
        cells.forEach((c, i) => placeBox(known, i, [c[0] - half, c[1] - half, c[2] - half],
                                         [c[0] + half, c[1] + half, c[2] + half]));
        known.instanceMatrix.needsUpdate = true;
        const knownGroup = new THREE.Group();
        knownGroup.add(known);
        layerGroups.push(["q" + index + "-known-" + flight.planner, flight.planner + ": known obstacles",
                          tint, knownGroup]);
      }
      const times = flight.t;
      maxFlightTime = Math.max(maxFlightTime, times.length ? times[times.length - 1] : 0);
      flights.push({query: index, line: line, vehicle: vehicle, known: known, times: times,
                    points: flight.points, cells: cells});
    }
    queryGroups.push(layerGroups);
  });
  document.getElementById("query-row").hidden = queryGroups.length <= 1;

  let currentQuery = -1;
  function showQuery(index) {
    for (const id of Object.keys(layers)) {
      if (id.startsWith("q")) {
        world3d.remove(layers[id].group);
        layers[id].input.parentElement.remove();
        delete layers[id];
      }
    }
    for (const h of layersDiv.querySelectorAll("h2.query")) h.remove();
    currentQuery = index;
    const groups = queryGroups[index] || [];
    if (groups.length) {
      heading(scene.queries[index].name);
      layersDiv.lastChild.className = "query";
    }
    for (const [id, label, colour, group, visible] of groups) {
      addLayer(id, label, colour, group, visible !== false);
    }
    resize();  // the panel's width changed with its layers: the view offset follows
    frame(scene.queries[index]);
    setTime(maxFlightTime);
  }

  // The camera frames the query (start, goal, trajectories and flights) in the part of the
  // canvas right of the panel: the picture is shifted by half the panel's width (a view
  // offset) and the camera stands back until the query's bounding sphere fits that part.
  const panel = document.getElementById("panel");
  // The canvas's size in CSS pixels (a hidden container reports 0: a default then).
  function viewSize() {
    return {width: container.clientWidth || 800, height: container.clientHeight || 600};
  }
  function clearWidth() {
    const {width} = viewSize();
    const covered = panel.getBoundingClientRect().right + 8;
    return width - covered >= 240 ? covered : 0;  // a narrow window: the panel floats over
  }
  function queryBounds(query) {
    const box = new THREE.Box3();
    if (!query) {
      box.setFromCenterAndSize(worldCentre, new THREE.Vector3(worldSize, worldSize, worldSize));
      return box;
    }
    box.expandByPoint(new THREE.Vector3().fromArray(query.start));
    box.expandByPoint(new THREE.Vector3().fromArray(query.goal));
    for (const path of [...query.trajectories, ...query.flights]) {
      for (const point of vectors(path.points)) box.expandByPoint(point);
    }
    return box;
  }
  function frame(query) {
    const sphere = queryBounds(query).getBoundingSphere(new THREE.Sphere());
    const radius = Math.max(sphere.radius, 2) + 0.5;  // the markers' size, and some air
    const {width, height} = viewSize();
    const visible = width - clearWidth();
    const halfVertical = camera.fov / 2 * Math.PI / 180;
    const halfHorizontal = Math.atan(Math.tan(halfVertical) * visible / height);
    const distance = radius / Math.sin(Math.min(halfVertical, halfHorizontal));
    controls.target.copy(sphere.center);
    const direction = new THREE.Vector3(-0.7, -1.2, 1.1).normalize();
    camera.position.copy(sphere.center).addScaledVector(direction, distance);
    controls.update();
  }
  // Where a point lands on the page (CSS pixels from the canvas's top left).
  function screenOf(point) {
    const ndc = new THREE.Vector3().fromArray(point).project(camera);
    const {width, height} = viewSize();
    return {x: (ndc.x + 1) / 2 * width, y: (1 - ndc.y) / 2 * height};
  }

  // ---- flight replay ------------------------------------------------------------------
  const timeInput = document.getElementById("time");
  const timeLabel = document.getElementById("time-label");
  function upperBound(sorted, value, key) {
    let low = 0;
    let high = sorted.length;
    while (low < high) {
      const middle = (low + high) >> 1;
      if (key(sorted[middle]) <= value) low = middle + 1; else high = middle;
    }
    return low;
  }
  function setTime(t) {
    timeInput.value = t;
    timeLabel.textContent = Number(t).toFixed(1) + " s";
    for (const f of flights) {
      if (f.query !== currentQuery || !f.times.length) continue;
      const k = Math.max(1, upperBound(f.times, t, (x) => x));
      f.line.geometry.setDrawRange(0, k);
      f.vehicle.position.set(f.points[3 * (k - 1)], f.points[3 * (k - 1) + 1], f.points[3 * (k - 1) + 2]);
      if (f.known) f.known.count = upperBound(f.cells, t, (c) => c[3]);
    }
    render();
  }
  if (flights.length) {
    document.getElementById("flight-controls").hidden = false;
    timeInput.max = maxFlightTime;
    timeInput.addEventListener("input", () => setTime(Number(timeInput.value)));
    const play = document.getElementById("play");
    let playing = null;
    play.addEventListener("click", () => {
      if (playing) { cancelAnimationFrame(playing); playing = null; play.textContent = "play"; return; }
      play.textContent = "pause";
      let last = performance.now();
      let t = Number(timeInput.value) >= maxFlightTime ? 0 : Number(timeInput.value);
      const step = (now) => {
        t = Math.min(maxFlightTime, t + 2 * (now - last) / 1000);  // twice real time
        last = now;
        setTime(t);
        if (t < maxFlightTime) playing = requestAnimationFrame(step); else { playing = null; play.textContent = "play"; }
      };
      playing = requestAnimationFrame(step);
    });
  }

  // ---- rendering ------------------------------------------------------------------------
  function resize() {
    const {width, height} = viewSize();
    renderer.setSize(width, height);
    camera.aspect = width / height;
    camera.setViewOffset(width, height, -clearWidth() / 2, 0, width, height);
    camera.updateProjectionMatrix();
    render();
  }
  function render() { renderer.render(world3d, camera); }
  controls.addEventListener("change", render);
  window.addEventListener("resize", resize);
  querySelect.addEventListener("change", () => showQuery(Number(querySelect.value)));

  // Pixels that are not the background (a test reads it to know the canvas is not blank) and
  // a digest of the picture.
  function paintedPixels() {
    render();
    const source = renderer.domElement;
    const canvas = document.createElement("canvas");
    canvas.width = source.width;
    canvas.height = source.height;
    const context = canvas.getContext("2d");
    context.drawImage(source, 0, 0);
    const data = context.getImageData(0, 0, canvas.width, canvas.height).data;
    const bg = [(BACKGROUND >> 16) & 255, (BACKGROUND >> 8) & 255, BACKGROUND & 255];
    let painted = 0;
    let digest = 0x811c9dc5;  // FNV-1a over the pixels: any change to the picture changes it
    for (let i = 0; i < data.length; i += 4) {
      if (Math.abs(data[i] - bg[0]) + Math.abs(data[i + 1] - bg[1]) + Math.abs(data[i + 2] - bg[2]) > 24) ++painted;
      for (let c = 0; c < 3; ++c) digest = Math.imul(digest ^ data[i + c], 16777619) >>> 0;
    }
    return {painted: painted, total: canvas.width * canvas.height, digest: digest};
  }

  resize();
  showQuery(0);
  window.kinolabViewer = {
    scene: scene,
    layers: () => Object.keys(layers),
    // The line segments a tree layer draws (after thinning).
    segments: (id) => layers[id].group.children[0].geometry.attributes.position.count / 2,
    paintedPixels: paintedPixels,
    screenOf: screenOf,
    setTime: setTime,
    setCut: (z) => { document.getElementById("cut").value = z; document.getElementById("cut").dispatchEvent(new Event("input")); },
    ready: true,
  };
})();
