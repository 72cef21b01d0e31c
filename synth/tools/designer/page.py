"""The designer's page: one HTML document with its style and script inline (no network, no library).

The 3D view is a 2D canvas with a perspective camera that orbits the figure (drag the background, or
drag with the right button; shift-drag pans, the wheel zooms, "reset view" or a double click restores
it): the stick figure of `synth.tools.designer.scene` with its joint axes as short segments, drawn far to
near with nearer segments thicker and more opaque; the task poses as frames whose origins are drag
handles (a drag moves the item in the view's plane, alt/ctrl-drag turns it about the view axis, the wheel
over a handle moves it along the view's depth), the tool path and the tool frame, animated by a play
button and a slider. Once the design behind is done the links are coloured by clearance (green: keep
the clearance, red: come closer). A 2D canvas needs no WebGL, so the page works in any browser, headless ones
included. The table edits every value of the task file in its own units; every change goes to the
server, which answers with the new state (the page decides nothing). ``window.mpsynthDesigner`` gives
tests the state and the screen position of each handle.
"""

CSS = r"""html, body { margin: 0; height: 100%; font: 13px/1.35 system-ui, sans-serif; color: #222; background: #f6f7f9; }
#app { display: flex; height: 100%; }
#side { width: 430px; overflow: auto; padding: 10px 12px; border-right: 1px solid #ddd; background: #fff; box-sizing: border-box; }
#main { flex: 1; position: relative; }
#view { position: absolute; inset: 0 0 44px 0; width: 100%; height: calc(100% - 44px); cursor: grab; touch-action: none; }
#bar { position: absolute; left: 0; right: 0; bottom: 0; height: 44px; display: flex; gap: 10px; align-items: center; padding: 0 12px; background: #fff; border-top: 1px solid #ddd; box-sizing: border-box; }
#slider { flex: 1; }
h1 { font-size: 16px; margin: 0 0 6px 0; }
.row { display: flex; gap: 6px; align-items: center; flex-wrap: wrap; margin: 6px 0; }
#status { padding: 6px 8px; border-radius: 4px; margin: 6px 0; white-space: pre-wrap; }
#status.ok { background: #e8f5e9; } #status.bad { background: #fdecea; color: #8a1c12; }
#design { padding: 6px 8px; border-radius: 4px; margin: 6px 0; background: #f1f1f1; white-space: pre-wrap; }
#design.free { background: #e8f5e9; } #design.collides { background: #fff3e0; } #design.failed { background: #fdecea; }
table { border-collapse: collapse; width: 100%; }
td, th { padding: 1px 3px; text-align: left; font-variant-numeric: tabular-nums; }
th { color: #555; font-weight: 600; border-bottom: 1px solid #ddd; }
.cell input[type=number], .cell input[type=text] { width: 72px; }
.miss { color: #b3261e; font-weight: 600; } .hit { color: #1b5e20; }
tr.miss td { background: #fdecea; } tr.hit td { background: #e8f5e9; }
#kind option:disabled { color: #9e9e9e; }
.item { border-top: 1px solid #eee; padding: 4px 0; }
.item b { display: inline-block; min-width: 64px; }
.cell { display: inline-flex; flex-direction: column; margin: 2px 4px 2px 0; font-size: 11px; color: #555; }
#message { color: #8a1c12; min-height: 1em; }
.fields button { font-size: 11px; padding: 0 4px; margin: 2px 3px 2px 0; }
"""

BODY = r"""<div id="app">
<div id="side">
  <h1 id="title">mpsynth design</h1>
  <div class="row">kind <select id="kind"></select> candidate <select id="pick"></select></div>
  <div class="row"><button id="undo" type="button">undo</button><button id="save" type="button">save task</button>
    <button id="write" type="button">write output</button><span id="timing"></span></div>
  <div id="message"></div>
  <div id="status"></div>
  <div id="design"></div>
  <table id="errors"><thead><tr><th>item</th><th>position error</th><th>angle error</th><th>tolerance</th></tr></thead><tbody></tbody></table>
  <h1 style="margin-top:10px">task</h1>
  <div id="settings"></div>
  <div id="items"></div>
</div>
<div id="main"><canvas id="view"></canvas>
  <div id="bar"><button id="play" type="button">&#9654;</button><button id="reset" type="button" title="reset view (or double-click the view)">reset view</button><input id="slider" type="range" min="0" max="0" value="0">
    <span id="frame"></span></div>
</div>
</div>"""

JS = r""""use strict";
(function () {
  var timings = [];  // ms from a change sent to its state drawn (bench/bench_designer.py)
  var S = null, frame = 0, playing = false, busy = false, queued = null, polling = null;
  var canvas = document.getElementById("view"), ctx = canvas.getContext("2d");
  var cam = { yaw: -0.9, pitch: 0.45, zoom: 1, pan: [0, 0], centre: [0, 0, 0], size: 1 };
  var $ = function (id) { return document.getElementById(id); };
  function api(name, body) {
    return fetch("api/" + name, body === undefined ? {} : { method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify(body) }).then(function (r) {
      return r.json().then(function (j) { if (!r.ok) throw new Error(j.error || r.statusText); return j; });
    });
  }
  function send(name, body) { // one request in flight; a newer change replaces a waiting one (turns add up)
    if (busy) {
      if (name === "turn" && queued && queued[0] === "turn" && queued[1].item === body.item)
        body = { item: body.item, axis: body.axis, degrees: body.degrees + queued[1].degrees };
      queued = [name, body]; return;
    }
    busy = true; $("message").textContent = "";
    var t0 = performance.now();
    api(name, body).then(function (st) {
      show(st); var ms = performance.now() - t0; timings.push(ms); $("timing").textContent = "update " + Math.round(ms) + " ms";
    })
      .catch(function (e) { $("message").textContent = e.message; })
      .then(function () { busy = false; if (queued) { var q = queued; queued = null; send(q[0], q[1]); } });
  }
  // ------------------------------------------------------------ camera: orbit about the figure's centre, perspective
  function basis() { // r: right, u: up, f: towards the viewer (task frame, z up)
    var cy = Math.cos(cam.yaw), sy = Math.sin(cam.yaw), cp = Math.cos(cam.pitch), sp = Math.sin(cam.pitch);
    return { r: [-sy, cy, 0], u: [-sp * cy, -sp * sy, cp], f: [cp * cy, cp * sy, sp] };
  }
  function scale() { return cam.zoom * 0.8 * Math.min(canvas.width, canvas.height) / (cam.size || 1); }
  var EYE = 3;  // the eye's distance from the centre, in figure sizes
  function proj(p) { // [x, y] canvas pixels, [2]: depth towards the viewer, [3]: perspective factor
    var b = basis(), k = scale(), d = [p[0] - cam.centre[0], p[1] - cam.centre[1], p[2] - cam.centre[2]];
    var z = d[0] * b.f[0] + d[1] * b.f[1] + d[2] * b.f[2], D = EYE * (cam.size || 1), s = D / Math.max(D - z, 0.05 * D);
    return [canvas.width / 2 + cam.pan[0] + k * s * (d[0] * b.r[0] + d[1] * b.r[1] + d[2] * b.r[2]),
      canvas.height / 2 + cam.pan[1] - k * s * (d[0] * b.u[0] + d[1] * b.u[1] + d[2] * b.u[2]), z, s];
  }
  // depth cues: segments are gathered, then drawn far to near, nearer ones thicker and more opaque
  var segs = [];
  function line(a, b, color, w, flat) { segs.push({ a: proj(a), b: proj(b), color: color, w: w, flat: !!flat }); }
  function flush() {
    var h = 0.5 * (cam.size || 1);
    segs.sort(function (p, q) { return (p.a[2] + p.b[2]) - (q.a[2] + q.b[2]); });
    segs.forEach(function (g) {
      var z = (g.a[2] + g.b[2]) / 2, near = Math.max(0, Math.min(1, 0.5 + 0.5 * z / h));
      ctx.globalAlpha = g.flat ? 1 : 0.35 + 0.65 * near;
      ctx.strokeStyle = g.color; ctx.lineWidth = g.flat ? g.w : g.w * (0.6 + 0.8 * near) * (g.a[3] + g.b[3]) / 2;
      ctx.lineCap = "round"; ctx.beginPath(); ctx.moveTo(g.a[0], g.a[1]); ctx.lineTo(g.b[0], g.b[1]); ctx.stroke();
    });
    ctx.globalAlpha = 1; segs = [];
  }
  var AX = ["#d32f2f", "#2e7d32", "#1565c0"];
  function frameAt(T, L, w) {
    var o = [T[0][3], T[1][3], T[2][3]];
    for (var i = 0; i < 3; i++) line(o, [o[0] + L * T[0][i], o[1] + L * T[1][i], o[2] + L * T[2][i]], AX[i], w);
  }
  var COLORS = ["#5c6bc0", "#26a69a", "#ef6c00", "#8d6e63", "#ab47bc", "#43a047", "#f9a825", "#00838f"];
  function current() {
    if (!S) return null;
    var bg = S.background;
    return bg && bg.scene && bg.revision === S.revision ? bg.scene : S.scene;
  }
  function clearance() { var bg = S && S.background; return bg && bg.clearance && bg.revision === S.revision ? bg.clearance : null; }
  function linkColor(name, k) { // by clearance once the design behind is done: green keeps it, red comes closer
    var c = clearance();
    if (!c) return k === 0 ? "#616161" : COLORS[k % COLORS.length];
    return name in c.bodies ? (c.bodies[name] < 0 ? "#b71c1c" : "#e53935") : "#2e7d32";
  }
  var drawn = {};  // what the last frame drew (tests): link name -> colour
  function draw() {
    var dpr = window.devicePixelRatio || 1;
    var w = Math.round(canvas.clientWidth * dpr), h = Math.round(canvas.clientHeight * dpr);
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    ctx.setTransform(1, 0, 0, 1, 0, 0); ctx.clearRect(0, 0, w, h);
    if (!S) return;
    var sc = current(), L = 0.08 * cam.size;
    drawn = {};
    if (sc) {
      var f = Math.min(frame, sc.t.length - 1);
      for (var i = 1; i < sc.path.length; i++) line(sc.path[i - 1], sc.path[i], "#9e9e9e", 1, true);
      sc.links.forEach(function (lk, k) {
        var P = lk.points[f], col = linkColor(lk.name, k);
        drawn[lk.name] = col;
        for (var i = 1; i < P.length; i++) line(P[i - 1], P[i], col, 5 * dpr);
        if (P.length > 2) line(P[P.length - 1], P[0], col, 5 * dpr);
      });
      sc.axes.forEach(function (ax) { line(ax.ends[f][0], ax.ends[f][1], "#212121", 3 * dpr); });
      frameAt(sc.tool[f], 1.4 * L, 3 * dpr);
    }
    (S.poses || []).forEach(function (T, i) { if (!S.points[i]) frameAt(T, L, 2 * dpr); });
    flush();
    (S.poses || []).forEach(function (T, i) {
      var p = proj([T[0][3], T[1][3], T[2][3]]), miss = S.errors[i] && !S.errors[i].within;
      ctx.fillStyle = miss ? "#d32f2f" : "#fbc02d"; ctx.strokeStyle = "#333"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.arc(p[0], p[1], 6 * dpr, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      if (drag && drag.item === i && drag.turn) { ctx.beginPath(); ctx.arc(p[0], p[1], 26 * dpr, 0, 2 * Math.PI); ctx.strokeStyle = "#1565c0"; ctx.stroke(); }
      ctx.fillStyle = "#222"; ctx.font = (12 * dpr) + "px sans-serif"; ctx.fillText(itemName(i), p[0] + 8 * dpr, p[1] - 8 * dpr);
    });
    $("frame").textContent = sc ? "frame " + (frame + 1) + "/" + sc.t.length : "";
  }
  function itemName(i) { return S.errors[i] ? S.errors[i].name : "item " + i; }
  function handleXY(i) { // CSS pixels of item i's handle in the page
    var T = S.poses[i], p = proj(pos(T)), r = canvas.getBoundingClientRect(), dpr = window.devicePixelRatio || 1;
    return [r.left + p[0] / dpr, r.top + p[1] / dpr];
  }
  // ------------------------------------------------------------ panel
  function fmt(x, d) { return x === null || x === undefined ? "-" : (Math.abs(x) < 1e-9 ? "0" : x.toPrecision(d || 4)); }
  function show(st) {
    var first = !S;
    S = st;
    if (first || st.scene && !cam.size) fit();
    $("title").textContent = "mpsynth design: " + st.source;
    fillKinds(st); fill($("pick"), st.candidates.map(function (c, i) { return (i + 1) + ": " + c; }), st.pick);
    var ok = !st.problem;
    $("status").className = ok ? "ok" : "bad";
    $("status").textContent = ok ? st.linkage.kind + " linkage: " + st.linkage.joints + " joints, " + st.linkage.loops +
      " loop(s); synthesized in " + st.ms + " ms" : "No linkage: " + st.problem;
    $("undo").disabled = !st.undo;
    $("write").title = st.written ? "writes " + st.written : "";
    var rows = st.errors.map(function (e) {
      var tol = e.tolerance ? fmt(e.tolerance[0]) + " " + st.unit + " / " + fmt(e.tolerance[1]) + " deg" : "exact";
      return "<tr class='" + (e.within ? "hit" : "miss") + "'><td>" + esc(e.name) + "</td><td>" + fmt(e.position, 3) + " " + st.unit +
        "</td><td>" + (e.angle === null ? "-" : fmt(e.angle, 3) + " deg") + "</td><td>" + tol + "</td></tr>";
    });
    $("errors").tBodies[0].innerHTML = rows.join("");
    showBackground(st);
    showTable(st);
    var sc = st.scene;
    $("slider").max = sc ? String(sc.t.length - 1) : "0";
    draw();
    document.body.dataset.revision = String(st.revision);
    poll(st);
  }
  function showBackground(st) {
    var bg = st.background, el = $("design");
    if (!bg || bg.revision !== st.revision) { el.className = ""; el.textContent = st.problem ? "" : "design: waiting"; return; }
    var drive = bg.drive ? "drive: " + bg.drive + "\n" : "";
    if (bg.stage === "running") { el.className = ""; el.textContent = drive + "design: collision-free search running..."; }
    else if (bg.stage === "done") {
      el.className = bg.free ? "free" : "collides";
      var c = bg.clearance, legend = c ? "\nlinks: green keep " + fmt(c.clearance, 3) + " " + st.unit + " apart" +
        (Object.keys(c.bodies).length ? ", red come closer (" + Object.keys(c.bodies).map(function (b) { return b + " " + fmt(c.bodies[b], 3); }).join(", ") + ")" : "") : "";
      el.textContent = drive + "design: " + bg.design + (bg.choice ? "\n(" + bg.choice + ")" : "") + legend;
    }
    else if (bg.stage === "failed") { el.className = "failed"; el.textContent = drive + "design: " + bg.problem; }
    else { el.className = ""; el.textContent = drive + "design: cancelled"; }
    el.dataset.stage = bg.stage;
  }
  function poll(st) {
    clearTimeout(polling);
    if (st.background && st.background.stage === "running")
      polling = setTimeout(function () { if (!busy) api("state").then(function (s) { if (s.revision === S.revision) show(s); else poll(S); }); else poll(S); }, 300);
  }
  function esc(s) { return String(s).replace(/[&<>"']/g, function (c) { return "&#" + c.charCodeAt(0) + ";"; }); }
  function fillKinds(st) { // kinds that cannot apply are greyed out, with the reason as their tooltip
    var sel = $("kind");
    sel.innerHTML = st.kinds.map(function (k) {
      return "<option value='" + esc(k.kind) + "'" + (k.problem && k.kind !== st.kind ? " disabled" : "") +
        (k.problem ? " title='" + esc(k.problem) + "'" : "") + ">" + esc(k.kind) + (k.problem ? " (n/a)" : "") + "</option>";
    }).join("");
    sel.value = st.kind;
  }
  function fill(sel, values, chosen) {
    sel.innerHTML = values.map(function (v, i) { return "<option value='" + (typeof chosen === "number" ? i : esc(v)) + "'>" + esc(v) + "</option>"; }).join("");
    sel.value = String(chosen);
  }
  function input(cell) {
    var v = cell.value, el = document.createElement("input");
    if (typeof v === "boolean") { el.type = "checkbox"; el.checked = v; }
    else if (typeof v === "number") { el.type = "number"; el.step = "any"; el.value = String(v); }
    else { el.type = "text"; el.value = v === null ? "" : String(v); el.disabled = v === null; }
    el.dataset.path = JSON.stringify(cell.path);
    el.addEventListener("change", function () {
      var val = el.type === "checkbox" ? el.checked : el.type === "number" ? parseFloat(el.value) : el.value;
      if (el.type === "number" && !isFinite(val)) { $("message").textContent = cell.label + ": not a number"; return; }
      send("edit", { path: cell.path, value: val });
    });
    var wrap = document.createElement("label"); wrap.className = "cell"; wrap.textContent = cell.label; wrap.appendChild(el);
    return wrap;
  }
  function showTable(st) {
    if (document.activeElement && document.activeElement.dataset && document.activeElement.dataset.path) return;
    var items = $("items"), settings = $("settings");
    items.innerHTML = ""; settings.innerHTML = "";
    st.items.forEach(function (group) {
      group.settings.forEach(function (c) { settings.appendChild(input(c)); });
      fieldButtons(settings, null, group.addable, group.removable);
      group.rows.forEach(function (row) {
        var div = document.createElement("div"); div.className = "item";
        var b = document.createElement("b"); b.textContent = (group.key || "item") + " " + row.index; div.appendChild(b);
        row.cells.forEach(function (c) { div.appendChild(input(c)); });
        fieldButtons(div, row.index, row.addable, row.removable);
        items.appendChild(div);
      });
    });
  }
  function fieldButtons(parent, item, add, remove) { // give or take a task field (tolerance, exact, velocity, order)
    var span = document.createElement("span"); span.className = "fields";
    [["add", add || [], "+ "], ["remove", remove || [], "\u2212 "]].forEach(function (a) {
      a[1].forEach(function (key) {
        var btn = document.createElement("button"); btn.type = "button"; btn.textContent = a[2] + key;
        btn.dataset.field = a[0] + ":" + (item === null ? "task" : item) + ":" + key;
        btn.addEventListener("click", function () { send(a[0], { item: item, key: key }); });
        span.appendChild(btn);
      });
    });
    parent.appendChild(span);
  }
  function fit() {
    var pts = (S.poses || []).map(function (T) { return [T[0][3], T[1][3], T[2][3]]; });
    if (S.scene) {
      S.scene.path.forEach(function (p) { pts.push(p); });
      S.scene.links.forEach(function (lk) { lk.points.forEach(function (P) { P.forEach(function (p) { pts.push(p); }); }); });
    }
    if (!pts.length) return;
    var lo = pts[0].slice(), hi = pts[0].slice();
    pts.forEach(function (p) { for (var k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], p[k]); hi[k] = Math.max(hi[k], p[k]); } });
    cam.centre = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2];
    cam.size = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
  }
  // ------------------------------------------------------------ mouse: drag a handle (alt/ctrl: turn it), orbit, pan, zoom
  var drag = null;
  function hit(x, y) {
    var dpr = window.devicePixelRatio || 1, best = -1, bd = 10 * dpr;
    (S && S.poses || []).forEach(function (T, i) {
      if (!S.items[0].rows[i] || !S.items[0].rows[i].movable) return;
      var p = proj([T[0][3], T[1][3], T[2][3]]), d = Math.hypot(p[0] - x, p[1] - y);
      if (d < bd) { bd = d; best = i; }
    });
    return best;
  }
  function pos(T) { return [T[0][3], T[1][3], T[2][3]]; }
  function angleAt(c, x, y) { return Math.atan2(-(y - c[1]), x - c[0]); } // counter-clockwise on the screen
  canvas.addEventListener("pointerdown", function (e) {
    var dpr = window.devicePixelRatio || 1, x = e.offsetX * dpr, y = e.offsetY * dpr, i = e.button === 0 ? hit(x, y) : -1;
    canvas.setPointerCapture(e.pointerId);
    drag = { x: e.clientX, y: e.clientY, item: i, pan: e.shiftKey || e.button === 1 };
    if (i >= 0) {
      var T = S.poses[i];
      drag.start = pos(T); drag.dx = 0; drag.dy = 0;
      drag.turn = (e.altKey || e.ctrlKey || e.metaKey) && !S.points[i];
      if (drag.turn) { drag.centre = proj(drag.start); drag.a0 = null; drag.axis = basis().f; drag.sent = 0; }
    }
    draw();
  });
  canvas.addEventListener("pointerup", function () { drag = null; draw(); });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y, dpr = window.devicePixelRatio || 1;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.item >= 0 && drag.turn) { // about the view axis through the pose, by the angle swept round its handle
      var mx = e.offsetX * dpr, my = e.offsetY * dpr, a = angleAt(drag.centre, mx, my);
      if (drag.a0 === null) { // the sweep starts once the pointer is off the handle's centre
        if (Math.hypot(mx - drag.centre[0], my - drag.centre[1]) > 8 * dpr) drag.a0 = a;
        return;
      }
      var deg = (a - drag.a0) * 180 / Math.PI;
      deg = ((deg + 540) % 360) - 180;
      if (Math.abs(deg - drag.sent) >= 0.5) {
        send("turn", { item: drag.item, axis: drag.axis, degrees: deg - drag.sent }); drag.sent = deg;
      }
    } else if (drag.item >= 0) {
      drag.dx += dx * dpr; drag.dy += dy * dpr;
      var b = basis(), k = scale() * proj(drag.start)[3], p = drag.start.slice();
      for (var j = 0; j < 3; j++) p[j] += (drag.dx * b.r[j] - drag.dy * b.u[j]) / k;
      var T = S.poses[drag.item]; T[0][3] = p[0]; T[1][3] = p[1]; T[2][3] = p[2];
      send("move", { item: drag.item, position: p });
    } else if (drag.pan) { cam.pan[0] += dx * dpr; cam.pan[1] += dy * dpr; }
    else { cam.yaw -= dx * 0.01; cam.pitch = Math.max(-1.55, Math.min(1.55, cam.pitch + dy * 0.01)); }
    draw();
  });
  canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
  canvas.addEventListener("wheel", function (e) { // over a handle: the pose along the view's depth; else zoom
    e.preventDefault();
    var dpr = window.devicePixelRatio || 1, i = hit(e.offsetX * dpr, e.offsetY * dpr), step = Math.max(-1, Math.min(1, e.deltaY * 0.01));
    if (i >= 0) {
      var T = S.poses[i], f = basis().f, p = pos(T), d = -0.02 * (cam.size || 1) * step;
      for (var j = 0; j < 3; j++) p[j] += d * f[j];
      T[0][3] = p[0]; T[1][3] = p[1]; T[2][3] = p[2];
      send("move", { item: i, position: p });
    } else cam.zoom *= Math.exp(-Math.max(-1, Math.min(1, e.deltaY * 0.0015)));
    draw();
  }, { passive: false });
  function resetView() { cam.yaw = -0.9; cam.pitch = 0.45; cam.zoom = 1; cam.pan = [0, 0]; fit(); draw(); }
  canvas.addEventListener("dblclick", resetView);
  $("reset").addEventListener("click", resetView);
  window.addEventListener("resize", draw);
  // ------------------------------------------------------------ controls
  $("kind").addEventListener("change", function (e) { send("kind", { kind: e.target.value }); });
  $("pick").addEventListener("change", function (e) { send("pick", { pick: parseInt(e.target.value, 10) }); });
  $("undo").addEventListener("click", function () { send("undo", {}); });
  $("save").addEventListener("click", function () {
    api("save", {}).then(function (r) { $("message").textContent = "saved " + r.path + (r.comments_kept ? " (comments kept)" : " (rewritten)"); })
      .catch(function (e) { $("message").textContent = e.message; });
  });
  $("write").addEventListener("click", function () {
    $("message").textContent = "writing...";
    api("write", {}).then(function (r) { $("message").textContent = "wrote " + r.written + " to " + r.out + " (" + r.files + " files)" + (r.design ? "; " + r.design : ""); })
      .catch(function (e) { $("message").textContent = e.message; });
  });
  var slider = $("slider"), playBtn = $("play");
  slider.addEventListener("input", function () { frame = parseInt(slider.value, 10); draw(); });
  function tick() {
    if (!playing) return;
    var sc = current(); if (sc) { frame = (frame + 1) % sc.t.length; slider.value = String(frame); draw(); }
    setTimeout(tick, 50);
  }
  playBtn.addEventListener("click", function () { playing = !playing; playBtn.innerHTML = playing ? "&#10073;&#10073;" : "&#9654;"; tick(); });
  window.mpsynthDesigner = { state: function () { return S; }, handleXY: handleXY, idle: function () { return !busy && !queued; },
    timings: function () { return timings.slice(); }, camera: function () { return JSON.parse(JSON.stringify(cam)); },
    drawn: function () { return Object.assign({}, drawn); } };
  api("state").then(show).catch(function (e) { $("message").textContent = e.message; });
})();
"""


def page_html() -> str:
    """The whole page."""
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n<title>mpsynth design</title>\n'
            f"<style>\n{CSS}</style>\n</head>\n<body>\n{BODY}\n<script>\n{JS}</script>\n</body>\n</html>\n")
