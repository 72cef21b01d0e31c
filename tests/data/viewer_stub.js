// Runs the viewer page's script in node with a stub DOM and a no-op WebGL context (tests/test_view.py):
// prints the labels (name@left,top) and the scale bar after the first frames are drawn.
const fs = require("fs");
const html = fs.readFileSync(process.argv[2], "utf8");
const data = html.match(/<script type="application\/json" id="mpsynth-data">([\s\S]*?)<\/script>/)[1];
const js = html.match(/<script>\n([\s\S]*?)<\/script>/)[1];
const els = {};
function mkEl(id) {
  return { id, style: {}, children: [], textContent: "", hidden: false, className: "", value: "0", max: "0", checked: true,
    clientWidth: 800, clientHeight: 600, width: 0, height: 0,
    appendChild(c) { this.children.push(c); return c; }, addEventListener() {}, setAttribute() {},
    getContext() { return new Proxy({}, { get: (t, k) => (k in t ? t[k] : (typeof k === "string" && k === k.toUpperCase() ? 1 : function () { return k.startsWith("create") ? {} : (k.startsWith("get") ? (k === "getShaderParameter" || k === "getProgramParameter" ? true : {}) : undefined); })) }); },
    getBoundingClientRect() { return { left: 0, top: 0, width: 800, height: 600 }; } };
}
global.document = { getElementById(id) { if (id === "mpsynth-data") return { textContent: data }; return els[id] || (els[id] = mkEl(id)); },
  createElement(t) { return mkEl(t); }, addEventListener() {} };
global.window = { location: { search: "" }, devicePixelRatio: 1, addEventListener() {}, matchMedia() { return { matches: false }; } };
let rafs = [];
global.requestAnimationFrame = (f) => { rafs.push(f); };
global.atob = (b) => Buffer.from(b, "base64").toString("binary");
eval(js);
for (let i = 0; i < 3 && rafs.length; i++) { const r = rafs; rafs = []; r.forEach((f) => f(0)); }
const labels = els["labels"].children;
console.log("labels", labels.length, labels.map((e) => e.textContent + "@" + e.style.left + "," + e.style.top).join(" "));
console.log("scale", els["scale-bar"] && els["scale-bar"].style.width, els["scale-text"] && els["scale-text"].textContent);
