/* ldbench report image viewer: plain JavaScript, no network, inlined into index.html.

   Click a thumbnail of an image grid to open it full size. Keys (see the help line of the viewer):
   1..9 pick an image (1 = reference), left/right step through them, space toggles reference <-> the
   last method shown, i / a / s / f / u show the image / absolute error / signed error / FLIP map / the
   rejection map of `score --test unbiased` (rows that have one), b shows
   reference and current side by side, + / - / mouse wheel zoom (nearest-neighbour pixels), drag pans,
   0 fits, Escape closes. Under the cursor: the pixel's exact float32 values (from values/*.js, which
   call ldbenchValues; scripts load from file:// where fetch() is blocked).

   Scripted state for tests and links: index.html#ldv=<grid anchor>&idx=<0-based image>&mode=<image|abs|
   signed|flip|unbiased>&sbs=1&zoom=<screen px per image px>&keys=<key,key,...>&at=<x>,<y>. The keys go through
   the same keydown handler as real key presses. The viewer element #ldv mirrors its state in data-*
   attributes (data-shown = the source of the image shown, data-zoom, data-mode, data-idx, data-sbs). */
(function () {
  "use strict";
  var MODES = ["image", "abs", "signed", "flip", "unbiased"];
  var MODE_NAMES = {image: "image", abs: "|error|", signed: "signed error", flip: "FLIP", unbiased: "unbiased test"};
  var grids = {};
  var values = {};
  var waiting = {};
  var st = {open: false, grid: null, idx: 0, prev: 1, mode: "image", sbs: false, zoom: 1, tx: 0, ty: 0,
            px: null};
  var el = {};

  window.ldbenchValues = function (key, w, h, c, b64) {
    var bin = atob(b64), u8 = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
    values[key] = {w: w, h: h, c: c, data: new Float32Array(u8.buffer)};
    var cbs = waiting[key] || [];
    delete waiting[key];
    cbs.forEach(function (f) { f(); });
  };

  function loadValues(rel) {
    if (!rel || values[rel] || waiting[rel]) return;
    waiting[rel] = [readout];
    var s = document.createElement("script");
    s.src = rel;
    s.onerror = function () { delete waiting[rel]; };
    document.head.appendChild(s);
  }

  function h(tag, cls, text) {
    var e = document.createElement(tag);
    if (cls) e.className = cls;
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function build() {
    var root = h("div", "ldv");
    root.id = "ldv";
    root.hidden = true;
    el.title = h("span", "ldv-title");
    el.items = h("span", "ldv-group");
    el.modes = h("span", "ldv-group");
    el.sbs = h("button", "", "side by side (b)");
    el.sbs.onclick = function () { setSbs(!st.sbs); };
    el.zoom = h("span", "ldv-zoom");
    el.links = h("span", "ldv-links");
    var close = h("button", "", "close (Esc)");
    close.onclick = closeViewer;
    var bar = h("div", "ldv-bar");
    [el.title, el.items, el.modes, el.sbs, el.zoom, el.links, close].forEach(function (x) { bar.appendChild(x); });
    el.stage = h("div", "ldv-stage");
    el.panes = [0, 1].map(function () {
      var pane = h("div", "ldv-pane"), img = h("img"), cap = h("div", "ldv-cap");
      img.draggable = false;
      pane.appendChild(img);
      pane.appendChild(cap);
      el.stage.appendChild(pane);
      return {pane: pane, img: img, cap: cap};
    });
    var foot = h("div", "ldv-foot");
    el.bar = h("img", "ldv-colorbar");
    el.range = h("span", "ldv-range");
    el.px = h("div", "ldv-px", "");
    el.px.id = "ldv-px";
    var help = h("div", "ldv-help", "1..9 image (1 = reference) · ←/→ step · space reference ↔ method · " +
                 "i image · a |error| · s signed error · f FLIP · u unbiased test · b side by side · +/−/wheel zoom · drag pan · " +
                 "0 fit · Esc close");
    [el.bar, el.range, el.px, help].forEach(function (x) { foot.appendChild(x); });
    root.appendChild(bar);
    root.appendChild(el.stage);
    root.appendChild(foot);
    document.body.appendChild(root);
    el.root = root;
    el.stage.addEventListener("wheel", function (e) {
      e.preventDefault();
      var pane = e.target.closest(".ldv-pane") || el.panes[st.sbs ? 1 : 0].pane;
      var r = pane.getBoundingClientRect();
      zoomAt(e.deltaY < 0 ? 1.25 : 0.8, e.clientX - r.left, e.clientY - r.top);
    }, {passive: false});
    var drag = null;
    el.stage.addEventListener("mousedown", function (e) { drag = {x: e.clientX, y: e.clientY}; e.preventDefault(); });
    window.addEventListener("mouseup", function () { drag = null; });
    el.stage.addEventListener("mousemove", function (e) {
      if (drag) {
        st.tx += e.clientX - drag.x;
        st.ty += e.clientY - drag.y;
        drag = {x: e.clientX, y: e.clientY};
        apply();
      }
      var pane = e.target.closest(".ldv-pane");
      if (!pane) return;
      var r = pane.getBoundingClientRect();
      st.px = [Math.floor((e.clientX - r.left - st.tx) / st.zoom), Math.floor((e.clientY - r.top - st.ty) / st.zoom)];
      readout();
    });
  }

  function grid() { return grids[st.grid]; }
  function item(i) { return grid().items[i]; }

  function source(it, mode) {
    if (mode === "image" || !it[mode]) return it.png;
    return it[mode];
  }

  function button(text, on, fn) {
    var b = h("button", on ? "on" : "", text);
    b.onclick = fn;
    return b;
  }

  function render() {
    var g = grid(), it = item(st.idx);
    el.title.textContent = g.title;
    el.items.textContent = "";
    g.items.forEach(function (x, i) {
      el.items.appendChild(button((i + 1) + " " + x.label, i === st.idx, function () { show(i); }));
    });
    el.modes.textContent = "";
    MODES.forEach(function (m) {
      if (m === "image" || g.bars[m]) {
        el.modes.appendChild(button(MODE_NAMES[m], m === st.mode, function () { setMode(m); }));
      }
    });
    el.sbs.className = st.sbs ? "on" : "";
    var shown = st.sbs ? [[item(0), "image"], [it, st.mode]] : [[it, st.mode]];
    el.panes.forEach(function (p, k) {
      var s = shown[k];
      p.pane.hidden = !s;
      if (!s) return;
      var src = source(s[0], s[1]);
      if (p.img.getAttribute("src") !== src) p.img.setAttribute("src", src);
      p.img.width = g.w;
      p.img.height = g.h;
      p.cap.textContent = s[0].label + (s[1] !== "image" && s[0][s[1]] ? " — " + MODE_NAMES[s[1]] :
                          (s[1] !== "image" ? " (no " + MODE_NAMES[s[1]] + " map: reference)" : ""));
    });
    var bar = st.mode !== "image" && it[st.mode] ? g.bars[st.mode] : null;
    el.bar.hidden = !bar;
    if (bar) el.bar.setAttribute("src", bar.png);
    el.range.textContent = !bar ? "" : bar.lo === null || bar.lo === undefined ? bar.label :
                           bar.label + ": " + bar.lo.toPrecision(3) + " … " + bar.hi.toPrecision(3);
    el.links.textContent = "";
    [["PNG", it.png], ["EXR", it.exr], ["map PNG", st.mode !== "image" ? it[st.mode] : null]].forEach(function (l) {
      if (!l[1]) return;
      var a = h("a", "", l[0]);
      a.href = l[1];
      a.target = "_blank";
      el.links.appendChild(a);
    });
    // state for scripts and tests, read back from the panes themselves
    var vis = el.panes.filter(function (p) { return !p.pane.hidden; });
    el.root.setAttribute("data-shown", vis[vis.length - 1].img.getAttribute("src"));
    el.root.setAttribute("data-left", vis.length > 1 ? vis[0].img.getAttribute("src") : "");
    el.root.setAttribute("data-mode", st.mode);
    el.root.setAttribute("data-idx", String(st.idx));
    el.root.setAttribute("data-sbs", st.sbs ? "1" : "0");
    loadValues(g.items[0].values);
    loadValues(it.values);
    loadValues(it.flip_values);
    apply();
    readout();
  }

  function apply() {
    el.panes.forEach(function (p) {
      p.img.style.transform = "translate(" + st.tx + "px," + st.ty + "px) scale(" + st.zoom + ")";
    });
    el.zoom.textContent = "zoom " + (st.zoom >= 1 ? st.zoom.toFixed(st.zoom % 1 ? 2 : 0) : st.zoom.toFixed(3)) + "×";
    el.root.setAttribute("data-zoom", String(st.zoom));
  }

  function paneSize() {
    var r = el.panes[st.sbs ? 1 : 0].pane.getBoundingClientRect();
    return [Math.max(r.width, 1), Math.max(r.height, 1)];
  }

  function fit() {
    var g = grid(), s = paneSize();
    var z = Math.min(s[0] / g.w, s[1] / g.h);
    st.zoom = z >= 1 ? Math.floor(z) : z;
    st.tx = Math.round((s[0] - g.w * st.zoom) / 2);
    st.ty = Math.round((s[1] - g.h * st.zoom) / 2);
    apply();
  }

  function zoomAt(f, cx, cy) {
    var nz = Math.min(Math.max(st.zoom * f, 0.05), 256);
    st.tx = cx - (cx - st.tx) * nz / st.zoom;
    st.ty = cy - (cy - st.ty) * nz / st.zoom;
    st.zoom = nz;
    apply();
  }

  function setZoom(z) {
    var s = paneSize();
    zoomAt(z / st.zoom, s[0] / 2, s[1] / 2);
  }

  function show(i) {
    if (i < 0 || i >= grid().items.length) return;
    if (i > 0) st.prev = i;
    st.idx = i;
    render();
  }

  function setMode(m) { st.mode = m; render(); }

  function setSbs(on) { st.sbs = on; render(); fit(); }

  function fmt(v) { return isFinite(v) ? v.toPrecision(5) : String(v); }

  function at(rel, x, y) {
    var v = values[rel];
    if (!v || x < 0 || y < 0 || x >= v.w || y >= v.h) return null;
    var o = (y * v.w + x) * v.c, out = [];
    for (var k = 0; k < v.c; k++) out.push(v.data[o + k]);
    return out;
  }

  function mean(a) { return a.reduce(function (s, x) { return s + x; }, 0) / a.length; }

  function readout() {
    if (!st.open || !st.px) return;
    var g = grid(), it = item(st.idx), x = st.px[0], y = st.px[1];
    if (x < 0 || y < 0 || x >= g.w || y >= g.h) { el.px.textContent = ""; return; }
    var parts = ["x " + x + ", y " + y];
    var ref = at(g.items[0].values, x, y), cur = at(it.values, x, y);
    if (!g.items[0].values) parts.push("no float values written (image or report over the size limit)");
    if (ref) parts.push("reference " + ref.map(fmt).join(", "));
    if (st.idx > 0 && cur) parts.push(it.label + " " + cur.map(fmt).join(", "));
    if (st.idx > 0 && ref && cur) parts.push("signed (mean) " + fmt(mean(cur) - mean(ref)));
    var fl = st.idx > 0 ? at(it.flip_values, x, y) : null;
    if (fl) parts.push("FLIP " + fmt(fl[0]));
    el.px.textContent = parts.join(" · ");
  }

  function openViewer(anchor, idx, mode) {
    if (!grids[anchor]) return false;
    st.open = true;
    st.grid = anchor;
    st.idx = Math.min(Math.max(idx | 0, 0), grids[anchor].items.length - 1);
    st.prev = st.idx > 0 ? st.idx : 1;
    st.mode = MODES.indexOf(mode) >= 0 ? mode : "image";
    st.px = null;
    el.px.textContent = "";
    el.root.hidden = false;
    document.body.classList.add("ldv-open");
    render();
    fit();
    return true;
  }

  function closeViewer() {
    st.open = false;
    el.root.hidden = true;
    document.body.classList.remove("ldv-open");
  }

  function onKey(e) {
    if (!st.open || e.ctrlKey || e.metaKey || e.altKey) return;
    var k = e.key, n = grid().items.length;
    if (k >= "1" && k <= "9") show(+k - 1);
    else if (k === "ArrowRight") show((st.idx + 1) % n);
    else if (k === "ArrowLeft") show((st.idx + n - 1) % n);
    else if (k === " " || k === "Spacebar") show(st.idx === 0 ? Math.min(st.prev, n - 1) : 0);
    else if (k === "i") setMode("image");
    else if (k === "a") setMode("abs");
    else if (k === "s") setMode("signed");
    else if (k === "f") setMode("flip");
    else if (k === "u") setMode("unbiased");
    else if (k === "b") setSbs(!st.sbs);
    else if (k === "+" || k === "=") setZoom(st.zoom * 2);
    else if (k === "-") setZoom(st.zoom / 2);
    else if (k === "0") fit();
    else if (k === "Escape") closeViewer();
    else return;
    e.preventDefault();
  }

  function fromHash() {
    var q = {};
    location.hash.replace(/^#/, "").split("&").forEach(function (kv) {
      var i = kv.indexOf("=");
      if (i > 0) q[decodeURIComponent(kv.slice(0, i))] = decodeURIComponent(kv.slice(i + 1));
    });
    if (!q.ldv || !openViewer(q.ldv, +(q.idx || 0), q.mode)) return;
    if (q.sbs === "1") setSbs(true);
    (q.keys ? q.keys.split(",") : []).forEach(function (k) {
      document.dispatchEvent(new KeyboardEvent("keydown", {key: k === "Space" ? " " : k, bubbles: true}));
    });
    if (q.zoom) setZoom(+q.zoom);
    if (q.at) {
      st.px = q.at.split(",").map(Number);
      el.root.setAttribute("data-at", q.at);
      readout();
    }
  }

  function init() {
    Array.prototype.forEach.call(document.querySelectorAll("script.ldv-data"), function (s) {
      var d = JSON.parse(s.textContent);
      grids[d.anchor] = d;
    });
    build();
    document.addEventListener("keydown", onKey);
    document.addEventListener("click", function (e) {
      var t = e.target.closest ? e.target.closest("[data-ldv]") : null;
      if (!t || e.ctrlKey || e.metaKey || e.shiftKey) return;
      if (openViewer(t.getAttribute("data-ldv"), +t.getAttribute("data-idx"), t.getAttribute("data-mode"))) {
        e.preventDefault();
      }
    });
    window.addEventListener("hashchange", fromHash);
    fromHash();
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", init);
  else init();
})();
