// insalign's 3D map viewer: plain WebGL 1, no library, so that a report opened from file://
// works offline in any browser. The points come from viewer_data.js (a <script> beside the page:
// a page from file:// may not fetch() a sibling file), which sets window.insalignViewerData =
// {meta: {...}, points: "<base64>"}. Binary layout (little-endian): for each extrinsic, N x 3
// uint16 positions quantised over meta.box; the points are grouped in runs (meta.runs:
// [frame, lidar, class, count]) so frame, LiDAR and class cost no bytes per point.
(function () {
  "use strict";
  const root = document.getElementById("insalign-viewer");
  if (!root) return;
  const status = document.getElementById("viewer-status");
  const errors = [];
  const say = (k, v) => status && status.setAttribute("data-" + k, String(v));
  const record = (m) => { errors.push(String(m)); say("errors", errors.join(" | ")); };
  window.addEventListener("error", (e) => record(e.message));
  const consoleError = console.error.bind(console);
  console.error = (...a) => { record(a.join(" ")); consoleError(...a); };
  const t0 = performance.now();
  const canvas = root.querySelector("canvas");
  const info = root.querySelector(".viewer-info");
  const fallback = (why) => {
    root.querySelector(".viewer-body").style.display = "none";
    root.querySelector(".viewer-fallback").style.display = "block";
    root.querySelector(".viewer-fallback").textContent = why;
    say("state", "fallback");
  };
  const D = window.insalignViewerData;
  if (!D) { fallback("The 3D view's data (" + root.getAttribute("data-src") + ") did not load."); return; }
  const gl = canvas.getContext("webgl", { antialias: false, preserveDrawingBuffer: true }) ||
             canvas.getContext("experimental-webgl", { preserveDrawingBuffer: true });
  if (!gl || new URLSearchParams(location.hash.slice(1)).has("nowebgl")) {
    fallback("WebGL is not available in this browser: " + root.getAttribute("data-fallback"));
    return;
  }
  root.querySelector(".viewer-fallback").style.display = "none";
  root.querySelector(".viewer-body").style.display = "block";
  const M = D.meta;

  // ---- Data: base64 to typed arrays -------------------------------------------------------------
  const bin = atob(D.points);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; ++i) bytes[i] = bin.charCodeAt(i);
  const N = M.points;
  const positions = M.extrinsics.map((_, e) => new Uint16Array(bytes.buffer, e * N * 6, N * 3));
  const attrib = new Uint8Array(N * 4);  // frame time (0-255), LiDAR, class, 0
  const framePerPoint = new Uint32Array(N);
  const nFrames = M.frame_times_s.length;
  const tFirst = nFrames ? M.frame_times_s[0] : 0, tLast = nFrames ? M.frame_times_s[nFrames - 1] : 1;
  let at = 0;
  for (const [frame, lidar, cls, count] of M.runs) {
    const tq = Math.round(255 * (M.frame_times_s[frame] - tFirst) / Math.max(tLast - tFirst, 1e-9));
    for (let k = 0; k < count; ++k, ++at) {
      attrib[4 * at] = tq; attrib[4 * at + 1] = lidar; attrib[4 * at + 2] = cls; framePerPoint[at] = frame;
    }
  }
  const scale = M.box.scale_m, boxMin = M.box.min_m;
  const centre = [0, 1, 2].map((k) => 0.5 * 65535 * scale[k]);  // local frame: the box's centre at 0
  const local = (p) => [0, 1, 2].map((k) => p[k] - boxMin[k] - centre[k]);

  // ---- GL programs ---------------------------------------------------------------------------------
  const compile = (vs, fs) => {
    const p = gl.createProgram();
    for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const s = gl.createShader(type);
      gl.shaderSource(s, src); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      gl.attachShader(p, s);
    }
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    return p;
  };
  const pointProgram = compile(`
    attribute vec3 q; attribute vec4 a;
    uniform mat4 mvp; uniform vec3 scale; uniform vec3 centre; uniform float size;
    uniform int mode; uniform float showLeftOut; uniform vec2 zRange;
    varying vec3 colour;
    vec3 ramp(float t) {
      vec3 c0 = vec3(40., 60., 170.), c1 = vec3(20., 150., 210.), c2 = vec3(50., 175., 80.),
           c3 = vec3(235., 195., 35.), c4 = vec3(215., 50., 40.);
      float s = clamp(t, 0., 1.) * 4.;
      vec3 c = s < 1. ? mix(c0, c1, s) : s < 2. ? mix(c1, c2, s - 1.) : s < 3. ? mix(c2, c3, s - 2.) : mix(c3, c4, s - 3.);
      return c / 255.;
    }
    vec3 palette(float l) {
      float k = mod(l, 6.);
      return k < .5 ? vec3(.9, .31, .24) : k < 1.5 ? vec3(.2, .47, .86) : k < 2.5 ? vec3(.16, .67, .31) :
             k < 3.5 ? vec3(.78, .59, .08) : k < 4.5 ? vec3(.59, .27, .75) : vec3(.08, .67, .7);
    }
    void main() {
      vec3 p = q * scale - centre;
      gl_Position = mvp * vec4(p, 1.);
      gl_PointSize = size;
      float cls = a.z * 255.;
      if (cls > .5) {
        // moving: magenta; bad INS: orange; outside the stretches a check used: grey
        colour = cls < 1.5 ? vec3(1., 0., 1.) : cls < 2.5 ? vec3(1., .55, 0.) : vec3(.62, .62, .62);
        if (showLeftOut < .5) gl_Position = vec4(2., 2., 2., 1.);  // outside the clip volume: not drawn
      } else if (mode == 0) {
        colour = ramp((p.z + centre.z - zRange.x) / max(zRange.y - zRange.x, 1e-3));
      } else if (mode == 1) {
        colour = palette(a.y * 255.);
      } else {
        colour = mix(vec3(.15, .2, .85), vec3(.95, .35, .1), a.x);
      }
    }`, `
    precision mediump float; varying vec3 colour;
    void main() { gl_FragColor = vec4(colour, 1.); }`);
  const lineProgram = compile(`
    attribute vec3 p; attribute vec3 c; uniform mat4 mvp; uniform float size; varying vec3 colour;
    void main() { gl_Position = mvp * vec4(p, 1.); gl_PointSize = size; colour = c; }`, `
    precision mediump float; varying vec3 colour;
    void main() { gl_FragColor = vec4(colour, 1.); }`);

  const buffer = (data) => { const b = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, b); gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW); return b; };
  const posBuffers = positions.map(buffer);
  const attribBuffer = buffer(attrib);
  // Overlays as (position, colour) float pairs: trajectory (line strip), fiducials (points, crosses), section boxes (lines).
  const traj = [], fid = [], boxes = [];
  const push = (arr, p, c) => arr.push(...local(p), ...c);
  for (const p of M.trajectory_m) push(traj, p, [0.1, 0.1, 0.1]);
  for (const f of M.fiducials) {
    const r = 1.0;  // a 2 m cross: visible from afar, its centre exact
    for (let k = 0; k < 3; ++k) {
      const a = f.p_m.slice(), b = f.p_m.slice(); a[k] -= r; b[k] += r;
      push(fid, a, [0.9, 0, 0]); push(fid, b, [0.9, 0, 0]);
    }
  }
  for (const s of M.sections) {
    const d = [s.across[1] * s.up[2] - s.across[2] * s.up[1], s.across[2] * s.up[0] - s.across[0] * s.up[2], s.across[0] * s.up[1] - s.across[1] * s.up[0]];
    const corner = (i, j, k) => [0, 1, 2].map((a) => s.centre_m[a] + i * s.half_across_m * s.across[a] + j * s.half_up_m * s.up[a] + k * s.half_depth_m * d[a]);
    const c = s.kind === "wall" ? [0.85, 0.1, 0.1] : [0.1, 0.3, 0.9];
    for (const [a, b] of [[[-1,-1,-1],[1,-1,-1]],[[-1,1,-1],[1,1,-1]],[[-1,-1,1],[1,-1,1]],[[-1,1,1],[1,1,1]],
                          [[-1,-1,-1],[-1,1,-1]],[[1,-1,-1],[1,1,-1]],[[-1,-1,1],[-1,1,1]],[[1,-1,1],[1,1,1]],
                          [[-1,-1,-1],[-1,-1,1]],[[1,-1,-1],[1,-1,1]],[[-1,1,-1],[-1,1,1]],[[1,1,-1],[1,1,1]]]) {
      push(boxes, corner(...a), c); push(boxes, corner(...b), c);
    }
  }
  const overlay = [[traj, gl.LINE_STRIP], [fid, gl.LINES], [boxes, gl.LINES]].filter(([a]) => a.length)
    .map(([a, mode]) => ({ buf: buffer(new Float32Array(a)), count: a.length / 6, mode }));

  // ---- Camera: orbit about a target ------------------------------------------------------------
  const extent = Math.hypot(...[0, 1, 2].map((k) => 65535 * scale[k]));
  const home = { target: [0, 0, 0], dist: 0.5 * extent, yaw: -0.6, pitch: 0.75 };
  const cam = Object.assign({}, home);
  const state = { ext: M.extrinsics.length - 1, mode: 0, leftOut: true, size: 2, overlays: true };
  const basis = () => {
    const cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch), cy = Math.cos(cam.yaw), sy = Math.sin(cam.yaw);
    const back = [cp * cy, cp * sy, sp];  // from the target to the eye
    const right = [-sy, cy, 0];
    const up = [-sp * cy, -sp * sy, cp];
    return { back, right, up };
  };
  const matrix = () => {
    const { back, right, up } = basis();
    const eye = [0, 1, 2].map((k) => cam.target[k] + cam.dist * back[k]);
    const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const view = [right[0], up[0], back[0], 0, right[1], up[1], back[1], 0, right[2], up[2], back[2], 0,
                  -dot(right, eye), -dot(up, eye), -dot(back, eye), 1];
    const near = Math.max(cam.dist * 0.01, 0.05), far = cam.dist + 2 * extent;
    const f = 1 / Math.tan(0.5 * 0.8), aspect = canvas.width / canvas.height;
    const proj = [f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0, 2 * far * near / (near - far), 0];
    const out = new Float32Array(16);
    for (let c = 0; c < 4; ++c) for (let r = 0; r < 4; ++r) {
      let s = 0;
      for (let k = 0; k < 4; ++k) s += proj[k * 4 + r] * view[c * 4 + k];
      out[c * 4 + r] = s;
    }
    return out;
  };

  // ---- Drawing -------------------------------------------------------------------------------------
  let pending = false, draws = 0;
  const draw = () => {
    pending = false;
    const w = Math.round(canvas.clientWidth * (window.devicePixelRatio || 1)), h = Math.round(canvas.clientHeight * (window.devicePixelRatio || 1));
    if (w > 0 && h > 0 && (canvas.width !== w || canvas.height !== h)) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, canvas.width, canvas.height);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    const mvp = matrix();
    gl.useProgram(pointProgram);
    const u = (n) => gl.getUniformLocation(pointProgram, n);
    gl.uniformMatrix4fv(u("mvp"), false, mvp);
    gl.uniform3fv(u("scale"), scale);
    gl.uniform3fv(u("centre"), centre);
    gl.uniform1f(u("size"), state.size);
    gl.uniform1i(u("mode"), state.mode);
    gl.uniform1f(u("showLeftOut"), state.leftOut ? 1 : 0);
    gl.uniform2f(u("zRange"), M.z_colour_m[0] - boxMin[2], M.z_colour_m[1] - boxMin[2]);
    const lq = gl.getAttribLocation(pointProgram, "q"), la = gl.getAttribLocation(pointProgram, "a");
    gl.bindBuffer(gl.ARRAY_BUFFER, posBuffers[state.ext]);
    gl.enableVertexAttribArray(lq); gl.vertexAttribPointer(lq, 3, gl.UNSIGNED_SHORT, false, 6, 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, attribBuffer);
    gl.enableVertexAttribArray(la); gl.vertexAttribPointer(la, 4, gl.UNSIGNED_BYTE, true, 4, 0);
    gl.drawArrays(gl.POINTS, 0, N);
    gl.disableVertexAttribArray(lq); gl.disableVertexAttribArray(la);
    if (state.overlays) {
      gl.useProgram(lineProgram);
      gl.uniformMatrix4fv(gl.getUniformLocation(lineProgram, "mvp"), false, mvp);
      gl.uniform1f(gl.getUniformLocation(lineProgram, "size"), 1);
      const lp = gl.getAttribLocation(lineProgram, "p"), lc = gl.getAttribLocation(lineProgram, "c");
      for (const o of overlay) {
        gl.bindBuffer(gl.ARRAY_BUFFER, o.buf);
        gl.enableVertexAttribArray(lp); gl.vertexAttribPointer(lp, 3, gl.FLOAT, false, 24, 0);
        gl.enableVertexAttribArray(lc); gl.vertexAttribPointer(lc, 3, gl.FLOAT, false, 24, 12);
        gl.drawArrays(o.mode, 0, o.count);
      }
      gl.disableVertexAttribArray(lp); gl.disableVertexAttribArray(lc);
    }
    // The camera and a draw count in the DOM: what the browser test reads after real input events.
    say("camera", [cam.yaw, cam.pitch, cam.dist, ...cam.target].map((v) => v.toFixed(4)).join(","));
    say("draws", ++draws);
  };
  const redraw = () => { if (!pending) { pending = true; requestAnimationFrame(draw); } };

  // ---- Controls --------------------------------------------------------------------------------------
  const modes = ["height", "LiDAR", "frame time"];
  const label = root.querySelector(".viewer-state");
  const update = () => {
    label.textContent = M.extrinsics[state.ext] + " · colour: " + modes[state.mode] + (state.leftOut ? "" : " · left-out hidden");
    say("extrinsic", M.extrinsics[state.ext]); say("mode", modes[state.mode]); say("leftout", state.leftOut);
    redraw();
  };
  const actions = {
    swap: () => { state.ext = (state.ext + 1) % M.extrinsics.length; update(); },
    colour: () => {  // by LiDAR only for rigs
      const avail = M.lidars.length > 1 ? [0, 1, 2] : [0, 2];
      state.mode = avail[(avail.indexOf(state.mode) + 1) % avail.length];
      update();
    },
    leftout: () => { state.leftOut = !state.leftOut; update(); },
    overlays: () => { state.overlays = !state.overlays; update(); },
    full: () => { root.classList.toggle("viewer-full"); redraw(); },
    home: () => { Object.assign(cam, home); cam.target = home.target.slice(); update(); },
    bigger: () => { state.size = Math.min(state.size + 1, 8); update(); },
    smaller: () => { state.size = Math.max(state.size - 1, 1); update(); },
  };
  const jump = (i) => {
    const s = M.sections[i];
    if (!s) return;
    const d = [s.across[1] * s.up[2] - s.across[2] * s.up[1], s.across[2] * s.up[0] - s.across[0] * s.up[2], s.across[0] * s.up[1] - s.across[1] * s.up[0]];
    // Look along the box's depth (edge-on, as the section picture), from a little above for the ground.
    const look = s.kind === "ground" ? [d[0] * 0.97, d[1] * 0.97, 0.25] : d;
    cam.target = local(s.centre_m);
    cam.dist = 4 * Math.max(s.half_across_m, s.half_up_m);
    cam.yaw = Math.atan2(look[1], look[0]);
    cam.pitch = Math.asin(Math.max(-1, Math.min(1, look[2] / Math.hypot(...look))));
    update();
  };
  for (const b of root.querySelectorAll("button[data-action]")) {
    b.addEventListener("click", () => {
      const a = b.getAttribute("data-action");
      if (a.startsWith("section")) jump(Number(a.slice(7))); else actions[a]();
    });
  }
  const keys = { b: "swap", " ": "swap", c: "colour", l: "leftout", o: "overlays", f: "full", r: "home", "+": "bigger", "=": "bigger", "-": "smaller" };
  document.addEventListener("keydown", (e) => {
    if (e.ctrlKey || e.altKey || e.metaKey || /INPUT|TEXTAREA|SELECT/.test(e.target.tagName)) return;
    if (keys[e.key]) { actions[keys[e.key]](); e.preventDefault(); }
    else if (e.key >= "1" && e.key <= "9") { jump(Number(e.key) - 1); e.preventDefault(); }
  });
  let drag = null;
  canvas.addEventListener("contextmenu", (e) => e.preventDefault());
  canvas.addEventListener("pointerdown", (e) => {
    canvas.focus();
    drag = { x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, pan: e.button !== 0 || e.shiftKey };
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) {
      const { right, up } = basis(), k = cam.dist * 1.7 / canvas.clientHeight;
      for (let i = 0; i < 3; ++i) cam.target[i] += k * (-dx * right[i] + dy * up[i]);
    } else {
      cam.yaw -= dx * 0.008;
      cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + dy * 0.008));
    }
    redraw();
  });
  canvas.addEventListener("pointerup", (e) => {
    if (drag && Math.hypot(e.clientX - drag.x0, e.clientY - drag.y0) < 4) pick(e);
    drag = null;
  });
  canvas.addEventListener("wheel", (e) => { cam.dist *= Math.exp(0.0015 * e.deltaY); e.preventDefault(); redraw(); }, { passive: false });

  // Click: the point nearest to the cursor on screen (within 8 px), the nearest to the eye among ties.
  const pick = (e) => {
    const r = canvas.getBoundingClientRect();
    const mx = (e.clientX - r.left) / r.width * 2 - 1, my = 1 - (e.clientY - r.top) / r.height * 2;
    const m = matrix(), q = positions[state.ext];
    const tol = 8 / r.width * 2, tol2 = tol * tol;
    let best = -1, bestScore = Infinity;
    for (let i = 0; i < N; ++i) {
      if (!state.leftOut && attrib[4 * i + 2]) continue;
      const x = q[3 * i] * scale[0] - centre[0], y = q[3 * i + 1] * scale[1] - centre[1], z = q[3 * i + 2] * scale[2] - centre[2];
      const w = m[3] * x + m[7] * y + m[11] * z + m[15];
      if (w <= 0) continue;
      const sx = (m[0] * x + m[4] * y + m[8] * z + m[12]) / w - mx, sy = ((m[1] * x + m[5] * y + m[9] * z + m[13]) / w - my) * r.height / r.width;
      const d2 = sx * sx + sy * sy;
      if (d2 > tol2) continue;
      const score = d2 / tol2 + w / extent;
      if (score < bestScore) { bestScore = score; best = i; }
    }
    if (best < 0) { info.textContent = "No point under the cursor."; return; }
    const p = [0, 1, 2].map((k) => boxMin[k] + q[3 * best + k] * scale[k]);
    const frame = framePerPoint[best], cls = attrib[4 * best + 2];
    info.textContent = `x ${p[0].toFixed(3)}  y ${p[1].toFixed(3)}  z ${p[2].toFixed(3)} m (world) · frame ${M.frame_names[frame]} ` +
      `(t = ${M.frame_times_s[frame].toFixed(3)} s)` + (M.lidars.length > 1 ? " · LiDAR " + M.lidars[attrib[4 * best + 1]] : "") +
      (cls === 1 ? " · left out: moving thing" : cls === 2 ? " · left out: bad INS stretch" :
       cls === 3 ? " · outside the stretches the check used" : "");
    say("picked", best);
  };

  // Initial state from the address (#extrinsic=0&colour=2&leftout=0&full&section=1): for links and screenshots.
  const h = new URLSearchParams(location.hash.slice(1));
  if (h.has("extrinsic")) state.ext = Math.min(Number(h.get("extrinsic")), M.extrinsics.length - 1);
  if (h.has("colour")) state.mode = Number(h.get("colour")) % 3;
  if (h.get("leftout") === "0") state.leftOut = false;
  if (h.has("full")) root.classList.add("viewer-full");
  if (h.has("section")) jump(Number(h.get("section")));
  update();
  draw();  // once now, so that a screenshot right after load shows the map
  say("load-ms", Math.round(performance.now() - t0));
  say("state", errors.length ? "error" : "ok");
})();
