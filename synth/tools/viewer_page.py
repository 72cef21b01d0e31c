"""The static part of the HTML viewer page (`synth.tools.viewer`): its style sheet and its WebGL script."""

VIEWER_CSS = r"""html, body { margin: 0; height: 100%; overflow: hidden; font: 13px/1.35 system-ui, -apple-system, "Segoe UI", sans-serif; color: #222; background: #f6f7f9; }
#view { position: absolute; inset: 0; width: 100%; height: 100%; display: block; touch-action: none; cursor: grab; }
#view:active { cursor: grabbing; }
#info { position: absolute; left: 12px; top: 10px; pointer-events: none; max-width: calc(100% - 24px); }
#title { font-size: 17px; font-weight: 600; }
#subtitle { color: #555; }
#state { color: #333; margin-top: 4px; font-variant-numeric: tabular-nums; white-space: pre-wrap; }
#help { position: absolute; right: 12px; top: 10px; color: #777; font-size: 12px; pointer-events: none; }
#labels .label { position: absolute; font-size: 12px; color: #222; background: rgba(255,255,255,0.75); padding: 0 3px; border-radius: 3px; pointer-events: none; }
#labels .label.world { color: #666; font-style: italic; }
#labels .label.joint { font-style: italic; font-size: 11px; color: #114; background: rgba(255,255,255,0.55); }
#scale { position: absolute; right: 16px; bottom: 56px; pointer-events: none; color: #333; font-size: 12px; text-align: center; }
#scale-bar { height: 6px; border: 2px solid #333; border-top: none; margin: 0 auto 2px auto; }
#bar { position: absolute; left: 0; right: 0; bottom: 0; display: flex; gap: 10px; align-items: center; padding: 8px 12px; background: rgba(255,255,255,0.85); border-top: 1px solid #ddd; }
#bar button { width: 34px; height: 28px; font-size: 14px; cursor: pointer; }
#slider { flex: 1; }
#frame { min-width: 92px; font-variant-numeric: tabular-nums; color: #444; }
#nogl { position: absolute; left: 50%; top: 45%; transform: translate(-50%, -50%); background: #fff; padding: 16px 20px; border: 1px solid #ccc; border-radius: 6px; }
"""

# A minimal WebGL 1 viewer written for mpsynth: flat-shaded triangle meshes with two lights, lines,
# RGB axis triads as small cylinders, an orbit camera, play/pause and a frame slider. URL options:
# ?frame=K shows frame K, ?play=1 starts playing.
VIEWER_JS = r""""use strict";
(function () {
  // ---------------------------------------------------------------- data
  var D = JSON.parse(document.getElementById("mpsynth-data").textContent);
  function f32(b64) {
    var s = atob(b64), n = s.length, u = new Uint8Array(n);
    for (var i = 0; i < n; i++) u[i] = s.charCodeAt(i);
    return new Float32Array(u.buffer);
  }
  var NF = D.frames;
  document.getElementById("title").textContent = D.title;
  document.getElementById("subtitle").textContent = D.subtitle;

  var canvas = document.getElementById("view");
  var gl = canvas.getContext("webgl", { antialias: true }) || canvas.getContext("experimental-webgl");
  if (!gl) { document.getElementById("nogl").hidden = false; return; }

  // ---------------------------------------------------------------- 4x4 matrices (column-major)
  function ident() { return new Float32Array([1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]); }
  function mul(a, b) {
    var o = new Float32Array(16);
    for (var c = 0; c < 4; c++) for (var r = 0; r < 4; r++) {
      var s = 0;
      for (var k = 0; k < 4; k++) s += a[k * 4 + r] * b[c * 4 + k];
      o[c * 4 + r] = s;
    }
    return o;
  }
  function perspective(fovy, aspect, near, far) {
    var f = 1 / Math.tan(fovy / 2), o = new Float32Array(16);
    o[0] = f / aspect; o[5] = f; o[10] = (far + near) / (near - far); o[11] = -1;
    o[14] = 2 * far * near / (near - far);
    return o;
  }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
  function norm(a) { var l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function lookAt(eye, at, up) {
    var z = norm(sub(eye, at)), x = norm(cross(up, z)), y = cross(z, x);
    return new Float32Array([x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0,
      -dot(x, eye), -dot(y, eye), -dot(z, eye), 1]);
  }
  function scaleM(sx, sy, sz) { var o = ident(); o[0] = sx; o[5] = sy; o[10] = sz; return o; }
  function slice16(arr, k) { return arr.subarray(16 * k, 16 * k + 16); }

  // ---------------------------------------------------------------- shaders
  function shader(type, src) {
    var s = gl.createShader(type);
    gl.shaderSource(s, src); gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
    return s;
  }
  function program(vs, fs, attrs, unis) {
    var p = gl.createProgram();
    gl.attachShader(p, shader(gl.VERTEX_SHADER, vs));
    gl.attachShader(p, shader(gl.FRAGMENT_SHADER, fs));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
    var o = { p: p, a: {}, u: {} };
    attrs.forEach(function (n) { o.a[n] = gl.getAttribLocation(p, n); });
    unis.forEach(function (n) { o.u[n] = gl.getUniformLocation(p, n); });
    return o;
  }
  var meshProg = program(
    "attribute vec3 pos; attribute vec3 nrm; uniform mat4 M; uniform mat4 V; uniform mat4 P;" +
    "varying vec3 vn; varying vec3 vp;" +
    "void main() { vec4 e = V * (M * vec4(pos, 1.0)); vp = e.xyz;" +
    " vn = (V * (M * vec4(nrm, 0.0))).xyz; gl_Position = P * e; }",
    "precision mediump float; uniform vec3 color; varying vec3 vn; varying vec3 vp;" +
    "void main() { vec3 n = normalize(vn); if (!gl_FrontFacing) n = -n;" +
    " vec3 v = normalize(-vp); vec3 l1 = normalize(vec3(-0.35, 0.6, 0.75)); vec3 l2 = normalize(vec3(0.5, -0.3, 0.4));" +
    " float d = max(dot(n, l1), 0.0) + 0.35 * max(dot(n, l2), 0.0);" +
    " float s = pow(max(dot(n, normalize(l1 + v)), 0.0), 48.0);" +
    " gl_FragColor = vec4(color * (0.28 + 0.72 * d) + vec3(0.22 * s), 1.0); }",
    ["pos", "nrm"], ["M", "V", "P", "color"]);
  var lineProg = program(
    "attribute vec3 pos; uniform mat4 M; uniform mat4 V; uniform mat4 P;" +
    "void main() { gl_Position = P * (V * (M * vec4(pos, 1.0))); }",
    "precision mediump float; uniform vec4 color; void main() { gl_FragColor = color; }",
    ["pos"], ["M", "V", "P", "color"]);

  // ---------------------------------------------------------------- geometry
  function meshBuffers(tri) { // triangle soup (x,y,z per corner) -> flat-shaded position + normal buffers
    var n = tri.length / 9, nrm = new Float32Array(tri.length);
    for (var i = 0; i < n; i++) {
      var o = 9 * i;
      var a = [tri[o + 3] - tri[o], tri[o + 4] - tri[o + 1], tri[o + 5] - tri[o + 2]];
      var b = [tri[o + 6] - tri[o], tri[o + 7] - tri[o + 1], tri[o + 8] - tri[o + 2]];
      var c = norm(cross(a, b));
      for (var k = 0; k < 3; k++) { nrm[o + 3 * k] = c[0]; nrm[o + 3 * k + 1] = c[1]; nrm[o + 3 * k + 2] = c[2]; }
    }
    var pb = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, pb); gl.bufferData(gl.ARRAY_BUFFER, tri, gl.STATIC_DRAW);
    var nb = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, nb); gl.bufferData(gl.ARRAY_BUFFER, nrm, gl.STATIC_DRAW);
    return { pos: pb, nrm: nb, count: 3 * n };
  }
  function cylinderSoup(sections) { // radius 1, z from 0 to 1, closed
    var out = [];
    for (var i = 0; i < sections; i++) {
      var a0 = 2 * Math.PI * i / sections, a1 = 2 * Math.PI * (i + 1) / sections;
      var p0 = [Math.cos(a0), Math.sin(a0)], p1 = [Math.cos(a1), Math.sin(a1)];
      out.push(p0[0], p0[1], 0, p1[0], p1[1], 0, p1[0], p1[1], 1);
      out.push(p0[0], p0[1], 0, p1[0], p1[1], 1, p0[0], p0[1], 1);
      out.push(0, 0, 0, p1[0], p1[1], 0, p0[0], p0[1], 0);
      out.push(0, 0, 1, p0[0], p0[1], 1, p1[0], p1[1], 1);
    }
    return new Float32Array(out);
  }
  function lineBuffer(arr) {
    var b = gl.createBuffer(); gl.bindBuffer(gl.ARRAY_BUFFER, b); gl.bufferData(gl.ARRAY_BUFFER, arr, gl.STATIC_DRAW);
    return { buf: b, count: arr.length / 3 };
  }

  var links = D.links.map(function (L) {
    var g = meshBuffers(f32(L.triangles));
    g.color = L.color; g.frames = f32(L.frames); g.name = L.name;
    return g;
  });
  var tool = f32(D.tool);
  var mount = D.mount ? f32(D.mount) : null, mountBuf = gl.createBuffer();
  var rod = meshBuffers(cylinderSoup(12));
  var path = lineBuffer(f32(D.path));
  var R = D.radius, FL = D.frame_length;
  // floor grid under the scene
  var gstep = Math.pow(10, Math.floor(Math.log10(R / 4)));
  if (R / gstep > 20) gstep *= 5; else if (R / gstep > 8) gstep *= 2;
  var grid = [], gn = Math.ceil(1.1 * R / gstep);
  for (var i = -gn; i <= gn; i++) {
    grid.push(i * gstep, -gn * gstep, D.floor, i * gstep, gn * gstep, D.floor);
    grid.push(-gn * gstep, i * gstep, D.floor, gn * gstep, i * gstep, D.floor);
  }
  var gridBuf = lineBuffer(new Float32Array(grid));
  // axis i of a frame: rotate the unit rod (+z) onto x, y or z
  var AXIS_ROT = [
    new Float32Array([0,0,-1,0, 0,1,0,0, 1,0,0,0, 0,0,0,1]),
    new Float32Array([1,0,0,0, 0,0,-1,0, 0,1,0,0, 0,0,0,1]),
    ident()];
  var AXIS_COL = [[0.86, 0.16, 0.16], [0.17, 0.63, 0.17], [0.14, 0.37, 0.86]];

  // ---------------------------------------------------------------- camera
  var cam = {};
  function resetView() {
    cam.yaw = D.view.azim * Math.PI / 180; cam.pitch = D.view.elev * Math.PI / 180;
    cam.dist = 2.7 * R; cam.target = [0, 0, 0];
  }
  resetView();
  var Vm, Pm;
  function eyePos() {
    var cp = Math.cos(cam.pitch);
    return [cam.target[0] + cam.dist * cp * Math.cos(cam.yaw), cam.target[1] + cam.dist * cp * Math.sin(cam.yaw),
      cam.target[2] + cam.dist * Math.sin(cam.pitch)];
  }

  // ---------------------------------------------------------------- drawing
  function drawMesh(g, M, color) {
    var pr = meshProg;
    gl.useProgram(pr.p);
    gl.uniformMatrix4fv(pr.u.M, false, M); gl.uniformMatrix4fv(pr.u.V, false, Vm); gl.uniformMatrix4fv(pr.u.P, false, Pm);
    gl.uniform3fv(pr.u.color, color);
    gl.bindBuffer(gl.ARRAY_BUFFER, g.pos); gl.enableVertexAttribArray(pr.a.pos);
    gl.vertexAttribPointer(pr.a.pos, 3, gl.FLOAT, false, 0, 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, g.nrm); gl.enableVertexAttribArray(pr.a.nrm);
    gl.vertexAttribPointer(pr.a.nrm, 3, gl.FLOAT, false, 0, 0);
    gl.drawArrays(gl.TRIANGLES, 0, g.count);
  }
  function drawLines(b, mode, color, M) {
    var pr = lineProg;
    gl.useProgram(pr.p);
    gl.uniformMatrix4fv(pr.u.M, false, M || ident()); gl.uniformMatrix4fv(pr.u.V, false, Vm);
    gl.uniformMatrix4fv(pr.u.P, false, Pm); gl.uniform4fv(pr.u.color, color);
    gl.bindBuffer(gl.ARRAY_BUFFER, b.buf); gl.enableVertexAttribArray(pr.a.pos);
    gl.vertexAttribPointer(pr.a.pos, 3, gl.FLOAT, false, 0, 0);
    gl.drawArrays(mode, 0, b.count);
  }
  function drawFrame(F, length, radius) {
    for (var i = 0; i < 3; i++) drawMesh(rod, mul(F, mul(AXIS_ROT[i], scaleM(radius, radius, length))), AXIS_COL[i]);
  }

  var frame = 0, playing = false, showPath = true, showPoses = true;
  var labelsDiv = document.getElementById("labels");
  var labelled = D.poses.map(function (p) { return { name: p.name, m: p.matrix, pose: true }; });
  if (D.world_label) labelled.push({ name: "world", m: D.world, pose: false });
  var jointPos = (D.joints || []).map(function (j) { return f32(j.pos); });
  var jointEls = (D.joints || []).map(function (j) {
    var el = document.createElement("div"); el.className = "label joint"; el.textContent = j.name;
    labelsDiv.appendChild(el); return el;
  });
  var labels = labelled.map(function (p) {
    var el = document.createElement("div"); el.className = "label" + (p.pose ? "" : " world"); el.textContent = p.name;
    labelsDiv.appendChild(el); return el;
  });

  function draw() {
    var dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, Math.round(canvas.clientWidth * dpr)), h = Math.max(1, Math.round(canvas.clientHeight * dpr));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    gl.viewport(0, 0, w, h);
    gl.clearColor(0.965, 0.968, 0.975, 1); gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    Pm = perspective(35 * Math.PI / 180, w / h, cam.dist * 0.01, cam.dist * 20 + 10 * R);
    Vm = lookAt(eyePos(), cam.target, [0, 0, 1]);
    drawLines(gridBuf, gl.LINES, [0.82, 0.83, 0.86, 1]);
    links.forEach(function (g) { drawMesh(g, slice16(g.frames, frame), g.color); });
    drawFrame(slice16(tool, frame), 2 * FL, 0.05 * FL);
    drawFrame(new Float32Array(D.world), FL, 0.025 * FL);
    if (showPoses) D.poses.forEach(function (p) { drawFrame(new Float32Array(p.matrix), FL, 0.03 * FL); });
    if (showPath) drawLines(path, gl.LINE_STRIP, [0.35, 0.35, 0.4, 1]);
    if (mount) {
      gl.bindBuffer(gl.ARRAY_BUFFER, mountBuf);
      gl.bufferData(gl.ARRAY_BUFFER, mount.subarray(6 * frame, 6 * frame + 6), gl.DYNAMIC_DRAW);
      drawLines({ buf: mountBuf, count: 2 }, gl.LINES, [0.95, 0.55, 0.12, 1]);
    }
    // labels: project the pose origins to the screen
    var PV = mul(Pm, Vm);
    labelled.forEach(function (p, i) {
      var m = p.m, x = m[12], y = m[13], z = m[14];
      var cx = PV[0] * x + PV[4] * y + PV[8] * z + PV[12], cy = PV[1] * x + PV[5] * y + PV[9] * z + PV[13];
      var cw = PV[3] * x + PV[7] * y + PV[11] * z + PV[15];
      var el = labels[i];
      if ((p.pose && !showPoses) || cw <= 0) { el.style.display = "none"; return; }
      el.style.display = "block";
      el.style.left = ((cx / cw + 1) / 2 * canvas.clientWidth + 6) + "px";
      el.style.top = ((1 - cy / cw) / 2 * canvas.clientHeight - 18) + "px";
    });
    jointEls.forEach(function (el, i) {
      var q = jointPos[i], x = q[3 * frame], y = q[3 * frame + 1], z = q[3 * frame + 2];
      var cx = PV[0] * x + PV[4] * y + PV[8] * z + PV[12], cy = PV[1] * x + PV[5] * y + PV[9] * z + PV[13];
      var cw = PV[3] * x + PV[7] * y + PV[11] * z + PV[15];
      if (cw <= 0) { el.style.display = "none"; return; }
      el.style.display = "block";
      el.style.left = ((cx / cw + 1) / 2 * canvas.clientWidth + 4) + "px";
      el.style.top = ((1 - cy / cw) / 2 * canvas.clientHeight - 8) + "px";
    });
    drawScale(PV);
    updateState();
  }

  // scale bar: a round length (1, 2 or 5 x 10^k m) about a fifth of the view wide, at the view's centre
  function screenX(PV, p) {
    var cx = PV[0] * p[0] + PV[4] * p[1] + PV[8] * p[2] + PV[12], cw = PV[3] * p[0] + PV[7] * p[1] + PV[11] * p[2] + PV[15];
    return (cx / cw + 1) / 2 * canvas.clientWidth;
  }
  function drawScale(PV) {
    var scaleBar = document.getElementById("scale-bar"), scaleText = document.getElementById("scale-text");
    var t = cam.target, r = [Vm[0], Vm[4], Vm[8]];
    var px = Math.abs(screenX(PV, [t[0] + r[0], t[1] + r[1], t[2] + r[2]]) - screenX(PV, t));  // pixels per metre
    if (!(px > 0) || !isFinite(px)) return;
    var want = canvas.clientWidth / 5 / px, k = Math.pow(10, Math.floor(Math.log10(want))), L = k;
    [1, 2, 5, 10].forEach(function (m) { if (m * k <= want) L = m * k; });
    scaleBar.style.width = Math.round(L * px) + "px";
    scaleText.textContent = L >= 1 ? L + " m" : (L >= 0.001 ? +(L * 1000).toPrecision(3) + " mm" : L.toExponential(0) + " m");
  }

  // ---------------------------------------------------------------- UI
  var slider = document.getElementById("slider"), playBtn = document.getElementById("play");
  var frameLbl = document.getElementById("frame"), state = document.getElementById("state");
  slider.max = String(NF - 1);
  function updateState() {
    var t = D.t[frame];
    frameLbl.textContent = "frame " + (frame + 1) + "/" + NF;
    var s = "t = " + (t === null ? "\u221e" : t.toPrecision(4));
    for (var name in D.angles) s += "   " + name + " = " + D.angles[name][frame].toFixed(1) + "\u00b0";
    var at = D.poses.filter(function (p) { return p.t === t; });
    if (at.length) s += "   (task pose " + at[0].name + ")";
    state.textContent = s;
  }
  var pending = false;
  function request() { if (!pending) { pending = true; requestAnimationFrame(function () { pending = false; draw(); }); } }
  function setFrame(k) { frame = ((k % NF) + NF) % NF; slider.value = String(frame); request(); }
  slider.addEventListener("input", function () { setFrame(parseInt(slider.value, 10)); });
  var last = 0, acc = 0, FRAME_MS = 4000 / NF;
  function tick(now) {
    if (!playing) return;
    if (last) acc += now - last;
    last = now;
    if (acc >= FRAME_MS) { setFrame(frame + Math.floor(acc / FRAME_MS)); acc %= FRAME_MS; }
    requestAnimationFrame(tick);
  }
  function setPlaying(on) {
    playing = on; playBtn.innerHTML = on ? "&#10073;&#10073;" : "&#9654;";
    if (on) { last = 0; acc = 0; requestAnimationFrame(tick); }
  }
  playBtn.addEventListener("click", function () { setPlaying(!playing); });
  document.getElementById("show-path").addEventListener("change", function (e) { showPath = e.target.checked; request(); });
  document.getElementById("show-poses").addEventListener("change", function (e) { showPoses = e.target.checked; request(); });
  window.addEventListener("keydown", function (e) {
    if (e.target.tagName === "INPUT" && e.target.type !== "range") return;
    if (e.key === " ") { setPlaying(!playing); e.preventDefault(); }
    else if (e.key === "ArrowRight") { setPlaying(false); setFrame(frame + 1); e.preventDefault(); }
    else if (e.key === "ArrowLeft") { setPlaying(false); setFrame(frame - 1); e.preventDefault(); }
  });

  // orbit (left drag), pan (shift / right drag), zoom (wheel, pinch)
  var drag = null;
  canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
  canvas.addEventListener("pointerdown", function (e) {
    canvas.setPointerCapture(e.pointerId);
    drag = { x: e.clientX, y: e.clientY, pan: e.shiftKey || e.button === 2 };
  });
  canvas.addEventListener("pointerup", function () { drag = null; });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag || pinch) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) {
      var s = 2 * cam.dist * Math.tan(35 * Math.PI / 360) / canvas.clientHeight;
      var right = [Vm[0], Vm[4], Vm[8]], up = [Vm[1], Vm[5], Vm[9]];
      for (var i = 0; i < 3; i++) cam.target[i] += s * (-dx * right[i] + dy * up[i]);
    } else {
      cam.yaw -= dx * 0.008;
      cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + dy * 0.008));
    }
    request();
  });
  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    cam.dist *= Math.exp(Math.max(-1, Math.min(1, e.deltaY * 0.0015)));
    request();
  }, { passive: false });
  canvas.addEventListener("dblclick", function () { resetView(); request(); });
  var pinch = null;
  canvas.addEventListener("touchstart", function (e) {
    if (e.touches.length === 2) pinch = Math.hypot(e.touches[0].clientX - e.touches[1].clientX, e.touches[0].clientY - e.touches[1].clientY);
  });
  canvas.addEventListener("touchmove", function (e) {
    if (e.touches.length !== 2 || !pinch) return;
    var d = Math.hypot(e.touches[0].clientX - e.touches[1].clientX, e.touches[0].clientY - e.touches[1].clientY);
    cam.dist *= pinch / Math.max(d, 1); pinch = d; e.preventDefault(); request();
  }, { passive: false });
  canvas.addEventListener("touchend", function () { pinch = null; });
  window.addEventListener("resize", request);

  var params = new URLSearchParams(window.location.search);
  if (params.has("frame")) setFrame(parseInt(params.get("frame"), 10) || 0);
  draw();
  if (params.get("play") === "1") setPlaying(true);
})();
"""
