// bootnav live view: strides and status pushed by the server as Server-Sent Events (no library, no network
// beyond this host). The path is drawn from above (east right, north up, equal scales), one colour per floor,
// one marker and label per boot at its newest footprint; the slider shows the recorded part up to a time.
// Provisional strides (the foot has just stopped; the final stride replaces them about 1.5 s later) are
// hollow markers on a thin dashed line after the newest final footprint. A boot's optional display offset
// (hello "offset_m", the demo's second walk) shifts its drawing only, never its figures.
"use strict";
(function () {
  const token = new URLSearchParams(location.search).get("token");
  const query = token ? "?token=" + encodeURIComponent(token) : "";
  const SVGNS = "http://www.w3.org/2000/svg";
  const state = { hello: null, boots: {}, tmax: 0, tview: 0, connected: false };
  window.bootnavLive = state;  // read by the browser test and handy in the console
  const $ = (id) => document.getElementById(id);
  let pending = false;

  function floorColor(floor) {
    const c = state.hello.floor_colors;
    return c[((floor % c.length) + c.length) % c.length];
  }

  function el(tag, attrs, parent) {
    const e = document.createElementNS(SVGNS, tag);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  }

  function niceStep(span) {
    const raw = span / 8, p = Math.pow(10, Math.floor(Math.log10(raw)));
    return [1, 2, 5, 10].map((m) => m * p).find((s) => s >= raw);
  }

  function visibleRows(rows) {
    if ($("follow").checked) return rows;
    let n = 0;
    while (n < rows.length && rows[n][0] <= state.tview) n++;
    return rows.slice(0, n);
  }

  function draw() {
    pending = false;
    const svg = $("map"), w = svg.clientWidth || 800, h = svg.clientHeight || 600;
    svg.setAttribute("viewBox", `0 0 ${w} ${h}`);
    let x0 = -1, x1 = 1, y0 = -1, y1 = 1;
    const shown = {};
    for (const id in state.boots) {
      const o = state.boots[id].offset;
      shown[id] = visibleRows(state.boots[id].rows);
      for (const r of shown[id].concat(visibleRows(state.boots[id].provisional))) { x0 = Math.min(x0, r[1] + o[0]); x1 = Math.max(x1, r[1] + o[0]); y0 = Math.min(y0, r[2] + o[1]); y1 = Math.max(y1, r[2] + o[1]); }
    }
    const pad = 30, k = Math.min((w - 2 * pad) / (x1 - x0), (h - 2 * pad) / (y1 - y0));
    const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    const gx0 = (x) => w / 2 + (x - cx) * k, gy0 = (y) => h / 2 - (y - cy) * k;
    let sx = gx0, sy = gy0;
    const grid = $("grid"), paths = $("paths"), heads = $("heads");
    grid.replaceChildren(); paths.replaceChildren(); heads.replaceChildren();
    const step = niceStep(Math.max((w / k), (h / k)));
    for (let gx = Math.ceil((cx - w / 2 / k) / step) * step; gx <= cx + w / 2 / k; gx += step) {
      el("line", { x1: gx0(gx), x2: gx0(gx), y1: 0, y2: h }, grid);
      el("text", { x: gx0(gx) + 2, y: h - 4 }, grid).textContent = `${+gx.toFixed(3)} m`;
    }
    for (let gy = Math.ceil((cy - h / 2 / k) / step) * step; gy <= cy + h / 2 / k; gy += step) {
      el("line", { x1: 0, x2: w, y1: gy0(gy), y2: gy0(gy) }, grid);
      el("text", { x: 2, y: gy0(gy) - 2 }, grid).textContent = `${+gy.toFixed(3)} m`;
    }
    for (const id in shown) {
      const rows = shown[id], boot = state.boots[id];
      sx = (x) => gx0(x + boot.offset[0]); sy = (y) => gy0(y + boot.offset[1]);
      for (let i = 1; i < rows.length;) {  // one polyline per run of strides ending on the same floor
        const f = rows[i][4];
        let j = i;
        while (j + 1 < rows.length && rows[j + 1][4] === f) j++;
        el("polyline", { class: "path", "data-boot": id, "data-floor": f, stroke: floorColor(f), "stroke-dasharray": boot.dash,
          points: rows.slice(i - 1, j + 1).map((r) => `${sx(r[1]).toFixed(1)},${sy(r[2]).toFixed(1)}`).join(" ") },
          paths);
        i = j + 1;
      }
      const prov = visibleRows(boot.provisional);
      if (prov.length) {
        const chain = (rows.length ? [rows[rows.length - 1]] : []).concat(prov);
        el("polyline", { class: "provisional", "data-boot": id, stroke: boot.color, "stroke-dasharray": "4 4",
          points: chain.map((r) => `${sx(r[1]).toFixed(1)},${sy(r[2]).toFixed(1)}`).join(" ") }, paths);
        for (const r of prov) {
          el("circle", { class: "provisional", "data-boot": id, "data-t": r[0], cx: sx(r[1]), cy: sy(r[2]), r: 5,
            stroke: boot.color }, heads);
        }
      }
      if (rows.length) {
        const r = rows[rows.length - 1];
        if (r.length > 7 && r[5] !== null) {  // the last stride's 1-σ ellipse (east right, north up: rotate by −θ)
          el("ellipse", { class: "unc", "data-boot": id, cx: sx(r[1]), cy: sy(r[2]), rx: Math.max(r[5] * k, 1),
            ry: Math.max(r[6] * k, 1), stroke: boot.color,
            transform: `rotate(${(-r[7] * 180 / Math.PI).toFixed(2)} ${sx(r[1]).toFixed(1)} ${sy(r[2]).toFixed(1)})` }, heads);
        }
        el("circle", { class: "head", "data-boot": id, cx: sx(r[1]), cy: sy(r[2]), r: 7, fill: boot.color }, heads);
        const t = el("text", { class: "headlabel", x: sx(r[1]) + 9, y: sy(r[2]) - 9, fill: boot.color }, heads);
        t.textContent = boot.label;
      }
    }
    timebar();
  }

  function schedule() {
    if (!pending) { pending = true; requestAnimationFrame(draw); }
  }

  function panel(id, boot) {
    const d = document.createElement("div");
    d.className = "boot"; d.id = `boot-${id}`; d.style.borderColor = boot.color;
    d.innerHTML = `<h2 style="color:${boot.color}"></h2>
      <div class="row"><span>floor</span><span class="big floor" id="floor-${id}">0</span></div>
      <div class="row"><span>height</span><span id="height-${id}">0.00 m</span></div>
      <div class="row"><span>uncertainty (1σ)</span><span id="unc-${id}">–</span></div>
      <div class="row"><span>distance</span><span id="dist-${id}">0.0 m</span></div>
      <div class="row"><span>strides</span><span id="strides-${id}">0</span></div>
      <div class="row"><span>no motion for</span><span id="still-${id}">0 s</span></div>
      <div class="row link" id="link-${id}"></div>
      <div class="alarm" id="alarm-${id}">NO MOTION</div>
      <div class="note" id="note-${id}"></div>`;
    d.querySelector("h2").textContent = boot.label;
    $("boots").appendChild(d);
  }

  function legend() {
    const lb = $("legend-boots"), lf = $("legend-floors");
    lb.replaceChildren(); lf.replaceChildren();
    for (const id in state.boots) {
      const b = state.boots[id], s = document.createElement("div");
      s.className = "legend-boot";
      s.innerHTML = `<svg class="swatch" viewBox="0 0 30 10"><line x1="0" y1="5" x2="30" y2="5" stroke="#555"
        stroke-width="3" stroke-dasharray="${b.dash}"/><circle cx="24" cy="5" r="4" fill="${b.color}"/></svg>`;
      s.appendChild(document.createTextNode(b.label));
      lb.appendChild(s);
    }
    const floors = new Set();
    for (const id in state.boots) for (const r of state.boots[id].rows) floors.add(r[4]);
    for (const f of [...floors].sort((a, b) => a - b)) {
      const s = document.createElement("div");
      s.className = "legend-floor";
      s.innerHTML = `<span class="swatch" style="background:${floorColor(f)}"></span>floor ${f}`;
      lf.appendChild(s);
    }
  }

  function onHello(msg) {
    state.hello = msg; state.boots = {}; state.tmax = 0;
    $("boots").replaceChildren();
    $("mode").textContent = msg.mode === "replay" ? `replay ×${msg.speed}` : "live";
    for (const b of msg.boots) {
      const dash = ["", "10 4", "3 4", "10 4 3 4"][Object.keys(state.boots).length % 4];  // tells boots apart
      state.boots[b.id] = { label: b.label, color: b.color, dash: dash, rows: [], provisional: [], status: null,
        offset: b.offset_m || [0, 0] };
      panel(b.id, b);
    }
    legend(); schedule();
  }

  function onStrides(msg) {
    const boot = state.boots[msg.boot];
    for (const r of msg.rows) { boot.rows.push(r); state.tmax = Math.max(state.tmax, r[0]); }
    legend(); schedule();
  }

  function onProvisional(msg) {
    const boot = state.boots[msg.boot];
    boot.provisional = msg.rows;
    for (const r of msg.rows) state.tmax = Math.max(state.tmax, r[0]);
    schedule();
  }

  function onStatus(msg) {
    for (const id in msg.boots) {
      const s = msg.boots[id], boot = state.boots[id];
      if (!boot) continue;
      boot.status = s;
      state.tmax = Math.max(state.tmax, s.t_s || 0);
      $(`floor-${id}`).textContent = s.floor;
      $(`height-${id}`).textContent = `${s.height_m.toFixed(2)} m`;
      $(`unc-${id}`).textContent = s.uncertainty_m ? `${s.uncertainty_m[0].toFixed(1)} × ${s.uncertainty_m[1].toFixed(1)} m` : "–";
      $(`dist-${id}`).textContent = `${s.distance_m.toFixed(1)} m`;
      $(`strides-${id}`).textContent = s.strides;
      $(`still-${id}`).textContent = `${s.still_s.toFixed(0)} s`;
      $(`alarm-${id}`).classList.toggle("on", s.alarm);
      $(`alarm-${id}`).textContent = s.alarm_reason === "signal lost" ? "SIGNAL LOST" : "NO MOTION";
      $(`note-${id}`).textContent = s.note || "";
      const L = s.link, link = $(`link-${id}`);
      const nominal = L.nominal_hz ? ` of ${(+L.nominal_hz).toFixed(0)}` : "";
      // one unbreakable part per figure: the line wraps between figures, never inside one
      const parts = [L.state, `${L.rate_hz.toFixed(0)}${nominal} Hz`, `drops ${L.dropped}`, `CRC ${L.crc_errors}`,
        `sat ${L.saturated}`];
      link.replaceChildren(...parts.map((p) => { const e = document.createElement("span"); e.textContent = p; return e; }));
      link.classList.toggle("stale", L.state !== "ok" && L.state !== "ended");
    }
    header();
    timebar();  // the path itself changes only with new strides
  }

  // the header says what matters: each boot's link (the page's own connection only when it is lost)
  function header() {
    const c = $("conn");
    if (!state.connected) { c.textContent = "page: reconnecting to bootnav…"; c.className = "bad"; return; }
    const ids = Object.keys(state.boots).filter((id) => state.boots[id].status);
    if (!ids.length) { c.textContent = "waiting for the boots…"; c.className = "bad"; return; }
    const st = ids.map((id) => [state.boots[id].label, state.boots[id].status.link.state]);
    c.textContent = st.map(([label, s]) => `${label}: ${s}`).join(" · ");
    c.className = st.every(([, s]) => s === "ok" || s === "ended") ? "ok" : "bad";
  }

  function timebar() {
    $("slider").max = state.tmax.toFixed(1);
    if ($("follow").checked) { state.tview = state.tmax; $("slider").value = state.tmax.toFixed(1); }
    $("tview").textContent = `${state.tview.toFixed(1)} s`;
  }

  function connect() {
    const es = new EventSource("events" + query);
    es.addEventListener("hello", (e) => onHello(JSON.parse(e.data)));
    es.addEventListener("strides", (e) => onStrides(JSON.parse(e.data)));
    es.addEventListener("provisional", (e) => onProvisional(JSON.parse(e.data)));
    es.addEventListener("status", (e) => onStatus(JSON.parse(e.data)));
    es.onopen = () => { state.connected = true; header(); };
    es.onerror = () => { state.connected = false; header(); };
  }

  $("slider").addEventListener("input", () => {
    $("follow").checked = false; state.tview = parseFloat($("slider").value); schedule();
  });
  $("follow").addEventListener("change", schedule);
  window.addEventListener("resize", schedule);
  connect();
})();
