// raylab live view: polls the render's progress and tiles, shows the quality knobs, and explains
// a clicked pixel with its ray tree and the rays drawn over the image. No build step, no library.
"use strict";

const $ = (id) => document.getElementById(id);
const image = $("image");
const overlay = $("overlay");
const ctx = image.getContext("2d");

// What this page has seen of the server's state.
const view = {
  version: 0, frame: 0, seq: 0, knobsVersion: 0, width: 1, height: 1, generation: 0, phase: "loading",
  settings: {}, knobs: [], zoom: "fit", picked: null, explained: null, highlight: null, explainedGeneration: 0,
};
// For tests and the curious: the last explanation and status, as the server sent them.
window.raylab = view;

function fmt(x) {
  if (x >= 1e9) return (x / 1e9).toFixed(2) + " G";
  if (x >= 1e6) return (x / 1e6).toFixed(2) + " M";
  if (x >= 1e3) return (x / 1e3).toFixed(1) + " k";
  return Math.round(x).toString();
}

function num(x) {
  if (x === null || x === undefined) return "∞";
  if (x === 0) return "0";
  const a = Math.abs(x);
  if (a >= 1e-3 && a < 1e6) return String(+x.toFixed(4));
  return x.toExponential(3);
}

const vec = (v) => "(" + v.map(num).join(", ") + ")";

function swatch(c) {
  const s = document.createElement("span");
  s.className = "swatch";
  const enc = (v) => {
    v = Math.min(Math.max(v, 0), 1);
    return Math.round(255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055));
  };
  s.style.background = `rgb(${enc(c[0])},${enc(c[1])},${enc(c[2])})`;
  s.title = "linear " + vec(c);
  return s;
}

function el(tag, cls, text) {
  const e = document.createElement(tag);
  if (cls) e.className = cls;
  if (text !== undefined) e.textContent = text;
  return e;
}

// ---- polling: status, controls and tiles in one answer ----

async function poll() {
  for (;;) {
    try {
      const q = `version=${view.version}&frame=${view.frame}&seq=${view.seq}&knobs=${view.knobsVersion}`;
      const r = await fetch("api/updates?" + q, { cache: "no-store" });
      if (!r.ok) throw new Error(r.status + " " + (await r.text()));
      apply(await r.arrayBuffer());
    } catch (e) {
      $("phase").textContent = "Lost the connection to raylab view (" + e.message + "); retrying…";
      await new Promise((res) => setTimeout(res, 1000));
    }
  }
}

function apply(buf) {
  const dv = new DataView(buf);
  const magic = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
  if (magic !== "RLV1") throw new Error("unexpected answer");
  const n = dv.getUint32(4, true);
  const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 8, n)));
  let at = 8 + n;
  if (head.frame) {
    if (head.frame.id !== view.frame) {
      view.frame = head.frame.id;
      view.width = head.frame.width;
      view.height = head.frame.height;
      image.width = view.width;
      image.height = view.height;
      setZoom(view.zoom);
    }
    for (const [x, y, w, h] of head.tiles) {
      const px = new Uint8ClampedArray(buf, at, w * h * 4);
      ctx.putImageData(new ImageData(px, w, h), x, y);
      at += w * h * 4;
    }
    view.seq = head.seq;
  }
  view.version = head.version;
  view.settings = head.settings;
  if (head.knobs) {
    view.knobs = head.knobs;
    view.knobsVersion = head.knobs_version;
    showKnobs();
  }
  showStatus(head.status);
}

function showStatus(s) {
  view.status = s;
  const newGeneration = s.generation !== view.generation;
  view.generation = s.generation;
  view.phase = s.phase;
  document.body.dataset.phase = s.phase;
  document.body.dataset.generation = s.generation;
  $("scene").textContent = s.scene;
  const pass = s.samples[1] > 1 ? ` — ${s.samples[0]} of ${s.samples[1]} samples per pixel` : "";
  const text = {
    loading: "Loading the scene…",
    preview: "Coarse preview…",
    rendering: `Rendering ${Math.round(100 * s.progress)} %${pass}`,
    refining: `Refining: ${s.samples[0]} samples per pixel shown, pass ${Math.round(100 * s.progress)} % (until the error target, ${s.samples[1]}, or Stop)`,
    done: s.ended ? `Done: ${s.ended}` : "Done",
    error: "Error",
  }[s.phase];
  $("phase").textContent = `${text}  ·  ${s.sampling}  ·  ${s.integrator}${s.denoised ? "  ·  denoised" : ""}`;
  $("stats").textContent = s.rays > 0 ? `${s.seconds.toFixed(2)} s  ·  ${fmt(s.rays)} rays  ·  ${fmt(s.rays_per_second)} rays/s` : "";
  $("bar").style.width = (s.phase === "done" ? 100 : 100 * s.progress) + "%";
  $("save").classList.toggle("disabled", s.phase !== "done" && s.phase !== "refining");
  $("stop").disabled = s.phase === "done" || s.phase === "error";
  const err = $("error");
  err.hidden = !s.error;
  if (s.error) {
    const e = s.error;
    $("error-where").textContent = e.file ? `${e.file}${e.line ? `, line ${e.line}, column ${e.column}` : ""}` : "";
    $("error-report").textContent = e.report;
  }
  const w = $("warnings");
  w.replaceChildren(...s.warnings.map((t) => el("li", "", "warning: " + t)));
  // A new render: the explained pixel is explained again with the new settings.
  if (newGeneration) view.explainedGeneration = 0;
  if (view.picked && view.explainedGeneration !== s.generation && (s.phase === "rendering" || s.phase === "done")) {
    view.explainedGeneration = s.generation;
    explain(view.picked, view.picked.sample);
  }
}

// ---- controls ----

function valueOf(k) {
  if (k.key.startsWith("params.")) {
    const name = k.key.slice(7);
    return view.settings.params && name in view.settings.params ? view.settings.params[name] : undefined;
  }
  return view.settings[k.key] === null ? undefined : view.settings[k.key];
}

function showKnobs() {
  for (const group of ["sampling", "image", "integrator"]) {
    const box = $("knobs-" + group);
    box.querySelectorAll(".knob").forEach((e) => e.remove());
    for (const k of view.knobs.filter((k) => k.group === group)) box.appendChild(knob(k));
  }
}

function knob(k) {
  const wrap = el("div", "knob" + (k.active ? "" : " inactive"));
  wrap.dataset.key = k.key;
  const label = el("label");
  const name = el("span", "", k.label);
  name.title = k.doc;
  label.appendChild(name);
  let input;
  if (k.kind === "choice") {
    input = el("select");
    for (const c of k.choices) {
      const o = el("option", "", c.label);
      o.value = c.value;
      o.title = c.doc;
      input.appendChild(o);
    }
    input.value = k.value;
  } else if (k.kind === "bool") {
    input = el("input");
    input.type = "checkbox";
    input.checked = !!k.value;
  } else {
    input = el("input");
    input.type = "number";
    input.step = k.kind === "int" ? "1" : "any";
    if (k.kind === "int") input.min = "0";
    if (k.key === "target_error") {
      input.min = "0";
      input.placeholder = "none";
    }
    input.value = k.value === null ? "" : k.value;
  }
  input.id = "knob-" + k.key.replace(".", "-");
  input.disabled = !k.active;
  input.title = k.doc;
  if (valueOf(k) !== undefined) input.classList.add("changed");
  input.addEventListener("change", () => change(k, input));
  label.appendChild(input);
  wrap.appendChild(label);
  let doc = k.doc;
  if (k.kind === "choice") {
    const c = k.choices.find((c) => c.value === k.value);
    if (c) doc = c.doc;
  }
  // The whole description (a knob's help cut at its first colon said less than it means); a note
  // on why the knob is inactive comes first.
  const line = el("div", "doc", k.note ? `${k.note}. ${doc}` : doc);
  line.title = doc;
  wrap.appendChild(line);
  return wrap;
}

function change(k, input) {
  const s = JSON.parse(JSON.stringify(view.settings));
  s.params = s.params || {};
  const knobValue = (key) => (view.knobs.find((x) => x.key === key) || {}).value;
  // An empty error target: none (the scene's own, if it has one).
  if (k.key === "target_error" && input.value.trim() === "") {
    delete s.target_error;
    delete s.target_min_spp;
    send(s);
    return;
  }
  let v;
  if (k.kind === "bool") v = input.checked;
  else if (k.kind === "choice") v = input.value;
  else if (k.kind === "int") v = Math.round(Number(input.value));
  else v = Number(input.value);
  if (typeof v === "number" && !Number.isFinite(v)) return;
  if (k.key.startsWith("params.")) s.params[k.key.slice(7)] = v;
  else s[k.key] = v;
  if (k.key === "integrator") s.params = {};
  // The adaptive knobs do not apply to stratified sampling (the scene loader refuses them).
  if (k.key === "aa" && v === "stratified") {
    for (const key of ["aa_threshold", "aa_depth", "aa_edges", "aa_signature", "aa_cell_samples", "aa_coarse"]) delete s[key];
  }
  // Nor does an error target apply to adaptive anti-aliasing.
  if (k.key === "aa" && v === "adaptive") {
    delete s.target_error;
    delete s.target_min_spp;
  }
  // With an error target, spp is the most samples a pixel takes in the scene's render: at least
  // the samples taken before the first test (refining goes on past it).
  if (k.key === "target_error" || k.key === "target_min_spp") {
    const least = k.key === "target_min_spp" ? v : knobValue("target_min_spp");
    if (Number(knobValue("spp")) < least) s.spp = least;
  }
  send(s);
}

async function send(settings) {
  const r = await fetch("api/settings", { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(settings) });
  if (!r.ok) {
    // The server answers {"error": "a sentence"}: show the sentence, not the JSON around it.
    const body = await r.text();
    let why = body;
    try {
      why = JSON.parse(body).error || body;
    } catch (_) {}
    $("phase").textContent = "The settings were refused: " + why;
  }
}

$("reset").addEventListener("click", () => send({ params: {} }));
$("stop").addEventListener("click", () => fetch("api/stop", { method: "POST" }));

// ---- zoom ----

function setZoom(z) {
  view.zoom = z;
  document.querySelectorAll("#zoombar button").forEach((b) => b.classList.toggle("on", b.dataset.zoom === String(z)));
  image.classList.toggle("fit", z === "fit");
  image.style.width = z === "fit" ? "" : view.width * z + "px";
  image.style.height = z === "fit" ? "" : view.height * z + "px";
  requestAnimationFrame(drawOverlay);
}

document.querySelectorAll("#zoombar button").forEach((b) =>
  b.addEventListener("click", () => setZoom(b.dataset.zoom === "fit" ? "fit" : Number(b.dataset.zoom))),
);
window.addEventListener("resize", () => requestAnimationFrame(drawOverlay));

// ---- the pixel inspector ----

function imagePoint(e) {
  const r = image.getBoundingClientRect();
  return { fx: ((e.clientX - r.left) / r.width) * view.width, fy: ((e.clientY - r.top) / r.height) * view.height };
}

image.addEventListener("mousemove", (e) => {
  const p = imagePoint(e);
  $("cursor").textContent = `pixel (${Math.floor(p.fx)}, ${Math.floor(p.fy)})`;
});

image.addEventListener("click", (e) => {
  const p = imagePoint(e);
  const x = Math.min(view.width - 1, Math.max(0, Math.floor(p.fx)));
  const y = Math.min(view.height - 1, Math.max(0, Math.floor(p.fy)));
  view.picked = { x, y, fx: p.fx, fy: p.fy, sample: undefined };
  view.explainedGeneration = view.generation;
  explain(view.picked);
});

$("sample-select").addEventListener("change", (e) => {
  if (!view.picked) return;
  view.picked.sample = Number(e.target.value);
  explain(view.picked, view.picked.sample);
});

async function explain(p, sample) {
  let q = `x=${p.x}&y=${p.y}&fx=${p.fx}&fy=${p.fy}`;
  if (sample !== undefined) q += `&sample=${sample}`;
  const r = await fetch("api/explain?" + q, { cache: "no-store" });
  const v = await r.json();
  $("inspect-hint").hidden = true;
  $("explain").hidden = false;
  if (!r.ok) {
    view.explained = null;
    $("pixel-head").textContent = v.error;
    $("tree").replaceChildren();
    drawOverlay();
    return;
  }
  view.explained = v;
  showExplanation(v);
  drawOverlay();
}

function showExplanation(v) {
  const head = $("pixel-head");
  head.replaceChildren();
  head.append(`Pixel (${v.pixel[0]}, ${v.pixel[1]}): sample colour `, swatch(v.color), ` ${vec(v.color)} → 8-bit ${v.rgb8.join(", ")}`);
  const sel = $("sample-select");
  sel.replaceChildren(
    ...v.samples.map((s) => {
      const o = el("option", "", `${s.index + 1} of ${v.samples.length} at (${num(s.at[0])}, ${num(s.at[1])}), weight ${num(s.weight)}`);
      o.value = s.index;
      return o;
    }),
  );
  sel.value = v.sample.index;
  const tree = $("tree");
  tree.replaceChildren();
  const trees = v.lens_rays || [v.tree];
  trees.forEach((t, i) => {
    if (trees.length > 1) tree.appendChild(el("h3", "", `lens ray ${i + 1} of ${trees.length}`));
    tree.appendChild(node(t, String(i)));
  });
}

const KIND = { camera: "camera ray", reflection: "reflection ray", refraction: "refraction ray", shadow: "shadow ray" };

function terms(list) {
  const box = el("div", "terms");
  for (const t of list) {
    const s = el("span");
    if (Array.isArray(t.value)) s.append(t.name + " ", swatch(t.value), vec(t.value));
    else s.textContent = `${t.name} ${num(t.value)}`;
    box.appendChild(s);
  }
  return box;
}

function row(label, text) {
  const r = el("div", "row");
  r.append(label + " ", Object.assign(el("b"), { textContent: text }));
  return r;
}

function node(n, id) {
  const d = el("details", "node");
  d.open = true;
  d.dataset.node = id;
  const sum = el("summary");
  const what = n.hit ? `hit ${n.hit.name}` : "missed: background";
  sum.append(`${KIND[n.kind] || n.kind} → ${what} `, Object.assign(el("span", "w"), { textContent: `depth ${n.depth}, weight ${vec(n.weight)}` }));
  d.appendChild(sum);
  sum.addEventListener("mouseenter", () => { view.highlight = id; d.classList.add("hl"); drawOverlay(); });
  sum.addEventListener("mouseleave", () => { view.highlight = null; d.classList.remove("hl"); drawOverlay(); });
  d.appendChild(row("origin", vec(n.ray.origin)));
  d.appendChild(row("direction", vec(n.ray.dir)));
  if (n.hit) {
    const h = n.hit;
    d.appendChild(row("hit", `${h.name} (object #${h.object}) at t = ${num(h.t)}, ${h.front_face ? "front" : "back"} face`));
    d.appendChild(row("point", vec(h.point)));
    d.appendChild(row("normal", vec(h.shading_normal)));
    if (n.terms.length) d.appendChild(terms(n.terms));
    for (const l of n.lights) {
      const state = l.skipped ? "skipped" : Math.max(...l.transmittance) <= 0 ? "blocked" : Math.max(...l.transmittance) < 1 ? "partial" : "lit";
      const box = el("div", "light " + state);
      const label = {
        lit: "lit (shadow ray reached the light)",
        blocked: `shadowed by ${l.occluder}`,
        partial: `partly shadowed by ${l.occluder}, transmittance ${vec(l.transmittance)}`,
        skipped: `no shadow ray: ${l.skipped}`,
      }[state];
      box.append(`light ${l.light}: `, Object.assign(el("span", "state"), { textContent: label }));
      if (!l.skipped) {
        box.appendChild(row("", `n·l ${num(l.n_dot_l)}, distance ${num(l.distance)}, intensity ${vec(l.intensity)}`));
        if (l.terms.length) box.appendChild(terms(l.terms));
      }
      d.appendChild(box);
    }
  }
  for (const note of n.notes) d.appendChild(el("div", "note", "note: " + note));
  n.children.forEach((c, i) => d.appendChild(node(c, `${id}.${i}`)));
  const res = el("div", "result");
  res.append("= colour ", swatch(n.color), vec(n.color));
  d.appendChild(res);
  return d;
}

// ---- the rays over the image ----

const COLORS = {
  reflection: "--reflection", refraction: "--refraction", shadow: "--lit",
  lit: "--lit", partial: "--partial", blocked: "--blocked", skipped: "--skipped",
};

function drawOverlay() {
  const r = image.getBoundingClientRect();
  const stage = $("stage").getBoundingClientRect();
  const dpr = window.devicePixelRatio || 1;
  overlay.style.left = r.left - stage.left + $("stage").scrollLeft + "px";
  overlay.style.top = r.top - stage.top + $("stage").scrollTop + "px";
  overlay.style.width = r.width + "px";
  overlay.style.height = r.height + "px";
  overlay.width = Math.max(1, Math.round(r.width * dpr));
  overlay.height = Math.max(1, Math.round(r.height * dpr));
  const g = overlay.getContext("2d");
  g.clearRect(0, 0, overlay.width, overlay.height);
  const v = view.explained;
  if (!v) return;
  const sx = overlay.width / view.width;
  const sy = overlay.height / view.height;
  const css = getComputedStyle(document.documentElement);
  const P = (p) => [p[0] * sx, p[1] * sy];
  g.lineCap = "round";
  // The clicked pixel and its samples.
  const [px, py] = P(v.pixel);
  g.strokeStyle = "#fff";
  g.lineWidth = 1.5 * dpr;
  g.strokeRect(px, py, sx, sy);
  for (const s of v.samples) {
    const [x, y] = P(s.at);
    g.fillStyle = s.index === v.sample.index ? "#fff" : "rgba(255,255,255,.45)";
    g.beginPath();
    g.arc(x, y, (s.index === v.sample.index ? 3 : 1.8) * dpr, 0, 2 * Math.PI);
    g.fill();
  }
  for (const m of v.marks) {
    const hl = view.highlight === null || m.node === view.highlight || m.node.startsWith(view.highlight + ".");
    g.globalAlpha = hl ? 1 : 0.25;
    const [x0, y0] = P(m.from);
    const [x1, y1] = P(m.to);
    if (m.kind === "hit") {
      g.fillStyle = "#fff";
      g.strokeStyle = "#000";
      g.lineWidth = 1.5 * dpr;
      g.beginPath();
      g.arc(x0, y0, 4.5 * dpr, 0, 2 * Math.PI);
      g.fill();
      g.stroke();
      continue;
    }
    const key = m.kind === "light" ? m.state : m.kind;
    g.strokeStyle = css.getPropertyValue(COLORS[key] || "--lit").trim();
    g.lineWidth = (m.kind === "light" ? 1.5 : 2.5) * dpr;
    g.setLineDash(m.state === "blocked" || m.state === "skipped" ? [5 * dpr, 4 * dpr] : m.state === "miss" ? [2 * dpr, 3 * dpr] : []);
    g.beginPath();
    g.moveTo(x0, y0);
    g.lineTo(x1, y1);
    g.stroke();
    g.setLineDash([]);
  }
  g.globalAlpha = 1;
}

poll();
