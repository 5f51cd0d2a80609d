// The raydamp page: a client of the service's own /v1 API, nothing more. It builds a job spec from
// the form, POSTs it, polls the job, then draws the trajectory with Plotly (served by this service).
"use strict";

const $ = (id) => document.getElementById(id);
const FINAL = new Set(["completed", "failed", "cancelled"]);
const PLOT_POINTS = 5000; // points fetched for the plots at most; the downloads carry every point
const POLL_MS = 250;

// structureMethods: GET /v1/structure_methods (newmark); springs: whether the system edited has springs.
const state = { models: [], methods: [], structureMethods: [], springs: false, examples: { models: {}, systems: [] },
  job: null, poll: null, overlays: [], followed: 0 }; // followed counts the jobs opened, so that a poll still in
// flight for an earlier one stops

// ---- talking to the service --------------------------------------------------------------------

// A service started with RAYDAMP_TOKEN answers /v1 with 401 until the request carries the token. The
// page asks for it once, keeps it for this tab only (sessionStorage) and sends it as a bearer header.
const TOKEN_KEY = "raydamp-token";

class NeedsToken extends Error {}

function authorization() {
  const token = sessionStorage.getItem(TOKEN_KEY);
  return token ? { Authorization: `Bearer ${token}` } : {};
}

async function api(url, options = {}) {
  const response = await fetch(url, { ...options, headers: { ...authorization(), ...(options.headers || {}) } });
  if (response.status === 401) {
    askForToken(sessionStorage.getItem(TOKEN_KEY) ? "that token was refused; try again" : "");
    throw new NeedsToken(`${url}: this service needs a token`);
  }
  return response;
}

async function getJSON(url) {
  const response = await api(url);
  if (!response.ok) throw new Error(`${url}: ${response.status} ${await response.text()}`);
  return response.json();
}

// ---- seeds: 64-bit integers ----------------------------------------------------------------------

// A JavaScript number holds integers exactly only up to 2^53, and a seed goes up to 2^64 - 1 (the
// service draws its seeds from the whole range): a seed travels as its digits, both ways.
const SEED_MARK = "\u0000raydamp seed\u0000";

class SeedDigits {
  constructor(digits) { this.digits = digits; }
  toJSON() { return SEED_MARK; }
}

// The JSON text of a spec, a SeedDigits seed written as the number it spells.
function specText(spec) {
  const text = JSON.stringify(spec);
  return spec.seed instanceof SeedDigits ? text.replace(JSON.stringify(SEED_MARK), spec.seed.digits) : text;
}

// A job view parsed, with job.spec.seedDigits the seed's digits exactly as the service wrote them (the
// reviver sees each number's source text; a browser without that falls back to the rounded number).
async function getJob(id) {
  const url = `/v1/jobs/${id}`;
  const response = await api(url);
  if (!response.ok) throw new Error(`${url}: ${response.status} ${await response.text()}`);
  const digits = new Map();
  const job = JSON.parse(await response.text(), function keepSeedDigits(key, value, context) {
    if (key === "seed" && context && typeof context.source === "string") digits.set(this, context.source);
    return value;
  });
  if (job.spec && job.spec.seed !== null && job.spec.seed !== undefined) {
    job.spec.seedDigits = digits.get(job.spec) || String(job.spec.seed);
  }
  return job;
}

function askForToken(message) {
  $("token-form").hidden = false;
  $("token-message").textContent = message;
  $("token").focus();
}

function useToken(event) {
  event.preventDefault();
  sessionStorage.setItem(TOKEN_KEY, $("token").value.trim());
  $("token").value = "";
  $("token-form").hidden = true;
  if (document.body.dataset.ready !== "true") loadPage(); else refreshJobs();
}

// A link cannot carry the header: with a token, a download is fetched and handed over as a blob.
async function download(event) {
  const link = event.target.closest("a[href]");
  if (!link || !sessionStorage.getItem(TOKEN_KEY)) return; // without a token the plain link works
  event.preventDefault();
  const response = await api(link.getAttribute("href"));
  if (!response.ok) { alert(`${link.textContent}: ${response.status} ${await response.text()}`); return; }
  const url = URL.createObjectURL(await response.blob());
  if (link.hasAttribute("download")) {
    const name = /filename="([^"]+)"/.exec(response.headers.get("content-disposition") || "");
    const save = Object.assign(document.createElement("a"), { href: url, download: name ? name[1] : "" });
    save.click();
  } else {
    window.open(url, "_blank");
  }
  setTimeout(() => URL.revokeObjectURL(url), 60_000);
}

// ---- the form ---------------------------------------------------------------------------------

function option(select, value, text) {
  const element = document.createElement("option");
  element.value = value;
  element.textContent = text;
  select.append(element);
}

function setNumbers(id, values) { $(id).value = values.join(", "); }

function showModel() {
  const model = state.models.find((m) => m.name === $("model").value);
  if (!model) return;
  $("model-description").textContent = `${model.description} (dim ${model.dim})`;
  const defaults = Object.fromEntries(model.parameters.map((p) => [p.name, p.default]));
  $("parameters").value = JSON.stringify(defaults);
  // The paper's initial data where we have them; otherwise q = (1, 0, ...), p = 0.
  const start = state.examples.models[model.name] ||
    { q: Array.from({ length: model.dim }, (_, i) => (i === 0 ? 1 : 0)), p: Array(model.dim).fill(0) };
  setNumbers("q", start.q);
  setNumbers("p", start.p);
  for (const key of ["step_size", "t_end", "save_every"]) if (start[key] !== undefined) $(key).value = start[key];
  loadDefaults(model.dim);
}

// ---- the load: none, a harmonic force, or an uploaded record as ground motion --------------------

// A force on the first coordinate and the ground moving every coordinate, sized to the system.
function loadDefaults(dim) {
  setNumbers("load-amplitude", Array.from({ length: dim }, (_, i) => (i === 0 ? 0.1 : 0)));
  setNumbers("record-direction", Array(dim).fill(1));
}

function showLoad() {
  const kind = $("load-kind").value;
  $("harmonic-fields").hidden = kind !== "harmonic";
  $("ground-fields").hidden = kind !== "ground";
  if (kind === "ground") refreshRecords();
}

function describeRecord(file) {
  const dt = file.dt !== null ? `, dt ${file.dt}` : "";
  return `${file.name} (${file.samples} samples${dt}, t ${file.t_start} to ${file.t_end})`;
}

// The records a ground motion can name: those with their own times (a one-column file needs a dt).
async function refreshRecords(select) {
  let list;
  try {
    list = await getJSON("/v1/files?limit=100");
  } catch (error) {
    return;
  }
  const records = list.files.filter((file) => file.kind === "record" && file.t_start !== null);
  const chosen = select || $("record").value;
  $("record").replaceChildren();
  for (const file of records) option($("record"), file.id, describeRecord(file));
  if (records.some((file) => file.id === chosen)) $("record").value = chosen;
}

// The upload is read and checked by the service (raydamp's reader): a bad file gets its reason here.
async function uploadRecord() {
  const file = $("record-file").files[0];
  if (!file) return;
  const message = $("record-message");
  message.className = "hint";
  message.textContent = `uploading ${file.name} ...`;
  const form = new FormData();
  form.append("file", file, file.name);
  let response;
  try {
    response = await api("/v1/files", { method: "POST", body: form });
  } catch (error) {
    if (!(error instanceof NeedsToken)) throw error;
    return;
  }
  const body = await response.json().catch(() => ({ detail: response.statusText }));
  if (response.status === 201 && body.kind === "record") {
    message.textContent = `uploaded ${describeRecord(body)}`;
    await refreshRecords(body.id);
  } else {
    message.className = "error";
    const detail = Array.isArray(body.detail) ? body.detail.map((d) => d.msg).join("; ") : body.detail;
    message.textContent = response.ok ? `${file.name} is a matrix, not a record` : `${response.status}: ${detail}`;
  }
  document.body.dataset.uploaded = String(Number(document.body.dataset.uploaded || 0) + 1);
}

function showExample() {
  const example = state.examples.systems[Number($("example").value)];
  if (!example) return;
  $("system").value = JSON.stringify(example.system, null, 2);
  setNumbers("q", example.q);
  setNumbers("p", example.p);
  loadDefaults(example.q.length);
  for (const key of ["step_size", "t_end", "save_every"]) $(key).value = example[key];
  offerMethods();
  $("method").value = example.method;
  showMethod();
}

function showSource() {
  const system = document.querySelector("input[name=source]:checked").value === "system";
  $("model-fields").hidden = system;
  $("system-fields").hidden = !system;
  if (system) showExample(); else showModel();
  offerMethods();
}

// The methods GET /v1/structure_methods lists (newmark) run a Structure with springs only: the menu offers
// them while the system being edited is one (its JSON's kind "structure" with springs), and not otherwise.
function editingSprings() {
  if (document.querySelector("input[name=source]:checked").value !== "system") return false;
  let system;
  try { system = JSON.parse($("system").value); } catch (error) { return false; }
  return system !== null && typeof system === "object" && system.kind === "structure" &&
    Array.isArray(system.springs) && system.springs.length > 0;
}

function offeredMethods() { return state.springs ? [...state.methods, ...state.structureMethods] : state.methods; }

// Fills the menu from the offered methods, keeping the choice where it is still offered (else 3s).
function fillMethods() {
  const chosen = $("method").value;
  const offered = offeredMethods();
  $("method").replaceChildren();
  for (const name of new Set(offered.map((m) => m.name))) {
    const rows = offered.filter((m) => m.name === name);
    option($("method"), name, `${name} (order ${Math.max(...rows.map((m) => m.order))}${rows[0].damped ? "" : ", undamped only"})`);
  }
  const fallback = offered.some((m) => m.name === "3s") ? "3s" : offered[0].name;
  $("method").value = offered.some((m) => m.name === chosen) ? chosen : fallback;
  if ($("method").value !== chosen) showMethod();
}

// Called as the system is edited: the menu changes only when the system becomes, or stops being, one with springs.
function offerMethods() {
  const springs = editingSprings();
  if (springs === state.springs) return;
  state.springs = springs;
  fillMethods();
}

function showMethod() {
  const name = $("method").value;
  const rows = offeredMethods().filter((m) => m.name === name);
  const tableau = $("tableau");
  tableau.replaceChildren();
  const tableaux = rows.filter((m) => m.tableau !== null);
  for (const m of tableaux) option(tableau, m.tableau, `${m.tableau} (order ${m.order})${m.default ? " (default)" : ""}`);
  const fallback = tableaux.find((m) => m.default);
  if (fallback) tableau.value = fallback.tableau;
  $("tableau-label").hidden = tableaux.length === 0;
  $("method-description").textContent = rows.length ? rows[0].description : "";
  showComposition();
}

// A composition raises a symmetric step's order (sv, 3s, 2s, rks with the midpoint tableau).
function showComposition() {
  const name = $("method").value;
  const tableau = $("tableau-label").hidden ? null : $("tableau").value;
  const row = offeredMethods().find((m) => m.name === name && (tableau === null || m.tableau === tableau));
  $("composition-label").hidden = !(row && row.symmetric);
}

// A number the user typed, or the text itself so that the service's 422 names the field.
function numberOr(text) {
  const trimmed = text.trim();
  const value = Number(trimmed);
  return trimmed !== "" && Number.isFinite(value) ? value : trimmed;
}

function numbers(text) { return text.split(/[,\s]+/).filter((s) => s !== "").map(numberOr); }

class FormError extends Error {
  constructor(loc, message) { super(message); this.loc = loc; }
}

function parseJSON(field, text) {
  try { return JSON.parse(text); } catch (error) { throw new FormError([field], `not valid JSON: ${error.message}`); }
}

function buildSpec() {
  const spec = {};
  if (document.querySelector("input[name=source]:checked").value === "system") {
    spec.system = parseJSON("system", $("system").value);
  } else {
    spec.model = $("model").value;
    spec.parameters = parseJSON("parameters", $("parameters").value || "{}");
  }
  spec.method = $("method").value;
  if (!$("tableau-label").hidden && $("tableau").value) spec.tableau = $("tableau").value;
  if (!$("composition-label").hidden && $("composition").value !== "none") spec.composition = $("composition").value;
  spec.step_size = numberOr($("step_size").value);
  spec.t_end = numberOr($("t_end").value);
  spec.save_every = numberOr($("save_every").value);
  spec.initial_state = { q: numbers($("q").value), p: numbers($("p").value) };
  const load = $("load-kind").value;
  if (load === "harmonic") {
    spec.load = { harmonic: { amplitude: numbers($("load-amplitude").value), omega: numberOr($("load-omega").value) } };
  } else if (load === "ground") {
    if (!$("record").value) throw new FormError(["ground_motion"], "upload a record first (.AT2, CSV or .npy)");
    spec.ground_motion = { acceleration: { file: { id: $("record").value, factor: numberOr($("record-factor").value) } },
      direction: numbers($("record-direction").value) };
  }
  // Thermal noise: sent only when asked for; a value that is not a number goes as typed, so that the
  // service's 422 names the field.
  const temperature = $("temperature").value.trim();
  if (temperature !== "") spec.temperature = numberOr(temperature);
  const seed = $("seed").value.trim();
  if (seed !== "") spec.seed = /^[0-9]+$/.test(seed) ? new SeedDigits(seed) : numberOr(seed);
  return spec;
}

// ["body", "system", "damping", "dampers", 0, "on"] -> "system.damping.dampers[0].on"
function jsonPath(loc) {
  return loc.filter((part, i) => !(i === 0 && part === "body"))
    .map((part, i) => (typeof part === "number" ? `[${part}]` : (i ? "." : "") + part)).join("");
}

// The form control a path belongs to, to outline it.
function controlFor(loc) {
  const parts = loc[0] === "body" ? loc.slice(1) : loc;
  if (parts[0] === "initial_state") return $(parts[1] === "p" ? "p" : "q");
  if (parts[0] === "load") return $(parts.includes("omega") ? "load-omega" : "load-amplitude");
  if (parts[0] === "ground_motion") {
    return $(parts[1] === "direction" ? "record-direction" : parts.includes("factor") ? "record-factor" : "record");
  }
  return $(String(parts[0])) || null;
}

function showErrors(errors) {
  const box = $("errors");
  for (const element of document.querySelectorAll(".invalid")) element.classList.remove("invalid");
  box.replaceChildren();
  box.hidden = errors.length === 0;
  for (const { loc, msg } of errors) {
    const line = document.createElement("div");
    let text = msg;
    if (loc && loc.length) {
      const path = document.createElement("code");
      path.textContent = jsonPath(loc);
      line.append(path, ": ");
      // raydamp's own messages start with the path already: show it once
      for (const prefix of [path.textContent + ": ", path.textContent + " "]) {
        if (text.startsWith(prefix)) { text = text.slice(prefix.length); break; }
      }
      const control = controlFor(loc);
      if (control) control.classList.add("invalid");
    }
    line.append(text);
    box.append(line);
  }
}

async function submit(event) {
  event.preventDefault();
  let spec;
  try {
    spec = buildSpec();
  } catch (error) {
    if (!(error instanceof FormError)) throw error;
    showErrors([{ loc: error.loc, msg: error.message }]);
    return;
  }
  $("submit").disabled = true;
  try {
    const response = await api("/v1/jobs", {
      method: "POST", headers: { "content-type": "application/json" }, body: specText(spec) });
    const body = await response.json().catch(() => ({ detail: response.statusText }));
    if (response.status === 422 && Array.isArray(body.detail)) {
      showErrors(body.detail);
    } else if (!response.ok) {
      showErrors([{ loc: null, msg: `${response.status}: ${typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail)}` }]);
    } else {
      showErrors([]);
      follow(body.id);
      refreshJobs();
    }
  } catch (error) {
    if (!(error instanceof NeedsToken)) throw error;
  } finally {
    $("submit").disabled = false;
  }
}

// ---- one job: progress, then results ------------------------------------------------------------

function follow(id) {
  if (state.poll) clearTimeout(state.poll);
  if (state.job && $("overlay").checked) keepOverlay();
  state.job = null;
  $("job").hidden = false;
  $("job-id").textContent = id;
  $("plots").dataset.ready = "false";
  $("plots").dataset.job = id;
  $("downloads").hidden = true;
  $("job-error").hidden = true;
  $("job-thermal").hidden = true;
  $("summary").replaceChildren();
  state.followed += 1;
  poll(id, state.followed);
}

async function poll(id, followed) {
  if (followed !== state.followed) return; // another job (or this one again) was opened meanwhile
  let job;
  try {
    job = await getJob(id);
  } catch (error) {
    $("job-status").textContent = String(error.message);
    return;
  }
  if (followed !== state.followed) return;
  showThermal(job);
  $("job-status").textContent = job.status;
  $("job-status").className = `status-${job.status}`;
  $("progress").value = job.progress;
  $("progress-text").textContent = `${Math.round(100 * job.progress)} %`;
  $("cancel").hidden = FINAL.has(job.status);
  if (!FINAL.has(job.status)) {
    state.poll = setTimeout(() => poll(id, followed), POLL_MS);
    return;
  }
  state.job = job;
  showFinished(job);
  refreshJobs();
}

// The job's temperature and seed, from the service's copy of the spec: the seed given, or the one the
// service drew at submission when none was (either repeats the run).
function showThermal(job) {
  const spec = job.spec;
  $("job-thermal").hidden = !spec.temperature;
  if (!spec.temperature) return;
  $("job-temperature").textContent = spec.temperature;
  $("job-seed").textContent = spec.seedDigits;
}

// A run driven by a load or by thermal noise gains energy from outside: what the damping took out is then its
// work W (the summary's energy_dissipated says so), not H(0) - H(t), and the row is named for it.
function showSummary(summary, spec) {
  const driven = Boolean(spec && (spec.load || spec.ground_motion || spec.temperature));
  const rows = [["steps", summary.steps], ["t final", summary.t_final], ["saved points", summary.saved_points],
    ["H initial", summary.energy_initial], ["H final", summary.energy_final],
    [driven ? "damping work W" : "energy dissipated", summary.energy_dissipated],
    ["momentum drift", summary.momentum_drift],
    ...(summary.load_work_final === null || summary.load_work_final === undefined ? [] : [
      ["load work W_f", summary.load_work_final], ["max |H − H0 + W − W_f|", summary.energy_balance_max]]),
    // at a temperature: ⟨pᵀ M⁻¹ p⟩ / n over the run's second half, to compare with kT
    ["kinetic temperature", summary.kinetic_temperature],
    ["wall time (s)", summary.wall_time]];
  const table = $("summary");
  table.replaceChildren();
  for (const [name, value] of rows) {
    if (value === null || value === undefined) continue;
    const row = table.insertRow();
    row.insertCell().textContent = name;
    row.insertCell().textContent = typeof value === "number" && !Number.isInteger(value) ? value.toPrecision(6) : value;
  }
}

async function showFinished(job) {
  if (job.error) {
    $("job-error").hidden = false;
    // The solver's message names its step already ("... at step 10"): said once.
    const step = job.failed_step ?? null;
    const named = step === null || job.error.includes(`step ${step}`);
    $("job-error").textContent = job.error + (named ? "" : ` (step ${step})`);
  }
  if (job.summary) showSummary(job.summary, job.spec);
  if (!job.trajectory) { $("plots").dataset.ready = "true"; return; } // nothing was computed
  for (const link of document.querySelectorAll("#downloads a[data-format]")) {
    link.href = `${job.trajectory}?format=${link.dataset.format}`;
  }
  for (const link of document.querySelectorAll("#downloads a[data-plot]")) {
    link.href = `/v1/jobs/${job.id}/plots/${link.dataset.plot}.png`;
  }
  $("downloads").hidden = false;
  const points = job.summary ? job.summary.saved_points : PLOT_POINTS;
  const every = Math.max(1, Math.ceil(points / PLOT_POINTS));
  const trajectory = await getJSON(`${job.trajectory}?every=${every}`);
  if (every > 1 && (points - 1) % every !== 0) {
    // Decimated, the last saved point (the run's end, or a blow-up's last finite state) is not among
    // every-th ones: it is fetched and drawn too.
    const last = await getJSON(`${job.trajectory}?start=${points - 1}`);
    for (const [key, values] of Object.entries(last)) {
      if (Array.isArray(values) && Array.isArray(trajectory[key])) trajectory[key].push(...values);
    }
  }
  if ($("job-id").textContent !== job.id) return;
  draw(job, trajectory);
  $("plots").dataset.ready = "true";
}

// ---- plots --------------------------------------------------------------------------------------

// The names of the saved coordinates: a system's own, else q0, q1, ...; a job that saved some coordinates
// only (save_dofs) has their columns, in its order.
function coordinateNames(spec, dim) {
  const coordinates = spec.system ? spec.system.coordinates : null;
  const name = (i) => (Array.isArray(coordinates) && coordinates[i] !== undefined ? coordinates[i] : `q${i}`);
  const saved = Array.isArray(spec.save_dofs) && spec.save_dofs.length === dim ? spec.save_dofs : null;
  return Array.from({ length: dim }, (_, k) => name(saved ? saved[k] : k));
}

function momentumNames(spec, count) {
  const declared = spec.system && spec.system.momenta ? Object.keys(spec.system.momenta) : [];
  const model = state.models.find((m) => m.name === spec.model);
  const names = declared.length ? declared : model ? model.momenta : [];
  return Array.from({ length: count }, (_, i) => names[i] || `m${i}`);
}

function label(job) {
  const spec = job.spec;
  // A built-in model's name; a system's own name, else its kind (chain, linear_structure).
  const system = spec.model || (spec.system && (spec.system.name || spec.system.kind)) || "system";
  const composed = spec.composition ? ` ∘ ${spec.composition}` : "";
  const tableau = spec.tableau ? "/" + (typeof spec.tableau === "string" ? spec.tableau : "own tableau") : "";
  const load = spec.ground_motion ? " + ground motion" : spec.load ? " + load" : "";
  return plotlyText(`${system} ${spec.method}${tableau}${composed} h=${spec.h ?? spec.step_size}${load}`);
}

// Plotly reads a trace's name as its own HTML subset (<b>, <a href>): a system's name is shown as written.
const plotlyText = (text) => text.replace(/&/g, "&amp;").replace(/</g, "&lt;").replace(/>/g, "&gt;");

const column = (rows, k) => rows.map((row) => row[k]);
const layout = (title, x, y, extra = {}) => ({
  title: { text: title }, xaxis: { title: { text: x } }, yaxis: { title: { text: y } },
  margin: { l: 60, r: 20, t: 40, b: 45 }, legend: { orientation: "h" }, ...extra });
const config = { responsive: true, displaylogo: false };

function keepOverlay() {
  const plot = $("plot-energy");
  if (plot.data) state.overlays = plot.data.map((trace) => ({ ...trace, line: { dash: "dot" } }));
}

// q_k(t) of the coordinate chosen: at first the one whose largest |q| is largest (a frame's roof, a
// cantilever's tip), then any other without fetching again.
function drawDisplacement(job, trajectory, names) {
  const select = $("displacement-dof");
  const k = Number(select.value);
  Plotly.newPlot("plot-displacement", [{ x: trajectory.t, y: column(trajectory.q, k), mode: "lines",
    name: `${plotlyText(names[k])}(t), ${label(job)}` }, ...eventMarkers(job, trajectory, k)],
  layout(`displacement ${plotlyText(names[k])}(t)`, "t", plotlyText(names[k]), { showlegend: false }), config);
}

// The job's event crossings (the summary's first 1000) as markers on q_k(t): at the crossing's own q where
// the summary lists it (a model of at most 8 coordinates), else on the line between the saved points.
function eventMarkers(job, trajectory, k) {
  const events = job.summary && job.summary.events;
  if (!events || !events.t.length) return [];
  const saved = Array.isArray(job.spec.save_dofs) ? job.spec.save_dofs[k] : k;
  const onLine = (t) => {
    const times = trajectory.t;
    const i = times.findIndex((s) => s >= t);
    if (i === -1) return trajectory.q[times.length - 1][k];
    if (i === 0) return trajectory.q[0][k];
    const s = (t - times[i - 1]) / (times[i] - times[i - 1]);
    return (1 - s) * trajectory.q[i - 1][k] + s * trajectory.q[i][k];
  };
  const y = events.q ? events.q.map((row) => row[saved]) : events.t.map(onLine);
  return [{ x: events.t, y, mode: "markers", name: "events", text: events.name.map(plotlyText),
    hovertemplate: "%{text}: t = %{x}<extra></extra>", marker: { symbol: "x", size: 9, color: "#d62728" } }];
}

function showDisplacement(job, trajectory, names) {
  const select = $("displacement-dof");
  select.replaceChildren();
  names.forEach((name, k) => option(select, k, name));
  $("displacement").hidden = names.length === 0;
  if (!names.length) { Plotly.purge($("plot-displacement")); return; }
  const peaks = new Array(names.length).fill(0);
  for (const row of trajectory.q) {
    row.forEach((v, k) => { if (v !== null && Math.abs(v) > peaks[k]) peaks[k] = Math.abs(v); });
  }
  select.value = String(peaks.indexOf(Math.max(...peaks)));
  select.onchange = () => drawDisplacement(job, trajectory, names);
  drawDisplacement(job, trajectory, names);
}

// A structure's springs by their coordinates: "springs[s]: q_i to q_j" ("q_j to the ground").
function springNames(job, count) {
  const system = job.spec.system || {};
  const springs = system.springs || [];
  const coordinate = (i) => (Array.isArray(system.coordinates) && system.coordinates[i] !== undefined
    ? system.coordinates[i] : `q${i}`);
  return Array.from({ length: count }, (_, s) => {
    const dofs = springs[s] ? springs[s].dofs : null;
    if (!dofs) return `springs[${s}]`;
    return dofs.length === 2 ? `springs[${s}]: ${coordinate(dofs[0])} to ${coordinate(dofs[1])}`
      : `springs[${s}]: ${coordinate(dofs[0])} to the ground`;
  });
}

// The force-deformation loop sigma_s(d_s) of the spring chosen: the library's force (from the material state of
// each saved point) against its deformation, both from the stored trajectory; at first the spring whose largest
// |d| is largest.
function drawLoop(job, trajectory, springs) {
  const s = Number($("loop-spring").value);
  Plotly.newPlot("plot-loop", [{ x: column(trajectory.spring_deformations, s), y: column(trajectory.spring_forces, s),
    mode: "lines", name: `${plotlyText(springs[s])}, ${label(job)}` }],
  layout(`force-deformation loop of ${plotlyText(springs[s])}`, "deformation d", "force σ(d)",
    { showlegend: false }), config);
}

function showLoop(job, trajectory) {
  const forces = trajectory.spring_forces;
  const count = Array.isArray(forces) && forces.length && Array.isArray(trajectory.spring_deformations)
    ? forces[0].length : 0;
  $("spring-loop").hidden = count === 0;
  const select = $("loop-spring");
  select.replaceChildren();
  if (!count) { Plotly.purge($("plot-loop")); return; }
  const springs = springNames(job, count);
  springs.forEach((name, s) => option(select, s, name));
  const peaks = new Array(count).fill(0);
  for (const row of trajectory.spring_deformations) {
    row.forEach((d, s) => { if (d !== null && Math.abs(d) > peaks[s]) peaks[s] = Math.abs(d); });
  }
  select.value = String(peaks.indexOf(Math.max(...peaks)));
  select.onchange = () => drawLoop(job, trajectory, springs);
  drawLoop(job, trajectory, springs);
}

function draw(job, trajectory) {
  const dim = trajectory.q.length ? trajectory.q[0].length : 0;
  const names = coordinateNames(job.spec, dim);
  const overlays = $("overlay").checked ? state.overlays : [];
  if (!$("overlay").checked) state.overlays = [];
  showDisplacement(job, trajectory, names);
  showLoop(job, trajectory);

  Plotly.newPlot("plot-energy", [...overlays,
    { x: trajectory.t, y: trajectory.energy, mode: "lines", name: label(job) }],
  layout("energy H(t)", "t", "H"), config);

  // H(t) - H(0) + W(t) - W_f(t): what the method lost or gained beyond the damping work W and the
  // load's work W_f (zero for the exact flow, O(h^2) for the order-2 splittings; the paper's measure
  // of dissipating at the right rate). Without a load W_f is 0.
  const balance = $("plot-balance");
  const loaded = Array.isArray(trajectory.load_work);
  // A structure's springs dissipate too: their hysteretic work, summed over the springs, enters the budget.
  const hysteretic = Array.isArray(trajectory.hysteretic_work)
    ? trajectory.hysteretic_work.map((row) => row.reduce((sum, w) => sum + w, 0)) : null;
  const springWork = (i) => (hysteretic ? hysteretic[i] : 0);
  const springTerm = hysteretic ? " + ΣW_h" : "";
  // At a temperature the noise brings energy that W does not count: there is no balance to show.
  balance.hidden = !Array.isArray(trajectory.work) || trajectory.energy.length === 0 || Boolean(job.spec.temperature);
  if (balance.hidden) {
    Plotly.purge(balance);
  } else {
    const h0 = trajectory.energy[0];
    const forced = (i) => (loaded ? trajectory.load_work[i] : 0);
    const what = `H - H0 + W${springTerm}${loaded ? " - W_f" : ""}`;
    Plotly.newPlot(balance, [{ x: trajectory.t,
      y: trajectory.energy.map((e, i) => e - h0 + trajectory.work[i] + springWork(i) - forced(i)), mode: "lines",
      name: `${what}, ${label(job)}` }],
    layout(`energy balance ${what}`, "t", "residual",
      { yaxis: { title: { text: "residual" }, exponentformat: "e" } }), config);
  }

  // The budget itself, under a load: the energy the load put in (W_f), what the damping took out (W),
  // and what the system holds (H - H0); the balance above is their difference.
  const budget = $("plot-budget");
  budget.hidden = balance.hidden || !loaded;
  if (budget.hidden) {
    Plotly.purge(budget);
  } else {
    const h0 = trajectory.energy[0];
    Plotly.newPlot(budget, [
      { x: trajectory.t, y: trajectory.load_work, mode: "lines", name: "W_f (load's work)" },
      { x: trajectory.t, y: trajectory.work, mode: "lines", name: "W (damping's work)" },
      ...(hysteretic ? [{ x: trajectory.t, y: hysteretic, mode: "lines", name: "ΣW_h (springs' hysteretic work)" }]
        : []),
      { x: trajectory.t, y: trajectory.energy.map((e) => e - h0), mode: "lines", name: "H - H0" }],
    layout(`energy budget: W_f = H - H0 + W${springTerm}`, "t", "energy"), config);
  }

  const phase = names.map((name, k) => ({
    x: column(trajectory.q, k), y: column(trajectory.p, k), mode: "lines", name: `(${name}, p_${name})` }));
  Plotly.newPlot("plot-phase", phase, layout("phase portraits", "q", "p"), config);

  const projection = $("plot-projection");
  projection.hidden = dim !== 2 && dim !== 3;
  if (projection.hidden) {
    Plotly.purge(projection);
  } else {
    Plotly.newPlot(projection, [{ x: column(trajectory.q, 0), y: column(trajectory.q, 1), mode: "lines",
      name: `(${names[0]}, ${names[1]})` }],
    layout("x-y projection", names[0], names[1], { yaxis: { title: { text: names[1] }, scaleanchor: "x" } }), config);
  }

  const count = trajectory.momentum.length ? trajectory.momentum[0].length : 0;
  const momentum = $("plot-momentum");
  momentum.hidden = count === 0;
  if (momentum.hidden) {
    Plotly.purge(momentum);
  } else {
    // The drift from the law the exact flow gives a momentum map, as the summary's figure:
    // J(0) e^{-a t} with a = eps c for a system whose damping is D = c M, else J(0).
    const system = job.spec.system || {};
    const a = system.damping && system.damping.scalar !== undefined ? (system.eps || 0) * system.damping.scalar : 0;
    const drift = momentumNames(job.spec, count).map((name, k) => {
      const values = column(trajectory.momentum, k);
      return { x: trajectory.t, y: values.map((v, i) => v - values[0] * Math.exp(-a * trajectory.t[i])),
               mode: "lines", name: a ? `${name}(t) - ${name}(0) e^(-${a} t)` : `${name}(t) - ${name}(0)` };
    });
    // Drifts are near rounding (1e-14): "2e-14" on the axis, not Plotly's SI "20f".
    Plotly.newPlot(momentum, drift, layout("momentum drift", "t", "drift",
      { yaxis: { title: { text: "drift" }, exponentformat: "e" } }), config);
  }
}

// ---- past jobs ----------------------------------------------------------------------------------

let refreshTimer = null;

async function refreshJobs() {
  if (refreshTimer) clearTimeout(refreshTimer);
  let list;
  try {
    list = await getJSON("/v1/jobs?limit=100");
  } catch (error) {
    return;
  }
  const body = document.querySelector("#jobs tbody");
  body.replaceChildren();
  for (const job of list.jobs) {
    const row = body.insertRow();
    row.dataset.job = job.id;
    row.insertCell().textContent = new Date(job.created_at).toLocaleString();
    row.insertCell().textContent = job.model;
    row.insertCell().textContent = job.method;
    const status = row.insertCell();
    status.textContent = FINAL.has(job.status) ? job.status : `${job.status} ${Math.round(100 * job.progress)} %`;
    status.className = `status-${job.status}`;
    const actions = row.insertCell();
    const show = document.createElement("button");
    show.textContent = "show";
    show.className = "show";
    show.addEventListener("click", () => follow(job.id));
    const remove = document.createElement("button");
    remove.textContent = FINAL.has(job.status) ? "delete" : "cancel";
    remove.className = "delete";
    remove.addEventListener("click", () => deleteJob(job.id));
    actions.append(show, " ", remove);
  }
  // The newest 100: say so when there may be more (the API lists up to max_list_limit, by status too).
  $("jobs-more").hidden = list.jobs.length < 100;
  if (list.jobs.some((job) => !FINAL.has(job.status))) refreshTimer = setTimeout(refreshJobs, 2000);
}

async function deleteJob(id) {
  // A finished job is removed (204); a queued or running one is cancelled (202).
  let response;
  try {
    response = await api(`/v1/jobs/${id}`, { method: "DELETE" });
  } catch (error) {
    if (error instanceof NeedsToken) return;
    throw error;
  }
  if (!response.ok && response.status !== 404) {
    const body = await response.json().catch(() => ({}));
    alert(`delete ${id}: ${response.status} ${body.detail || ""}`);
  }
  if (response.status === 204 && $("job-id").textContent === id) $("job").hidden = true;
  refreshJobs();
}

// ---- start --------------------------------------------------------------------------------------

// The controls work before the catalogue is loaded; load() runs again once a token is given.
function wire() {
  $("model").addEventListener("change", showModel);
  $("example").addEventListener("change", showExample);
  $("method").addEventListener("change", showMethod);
  $("load-kind").addEventListener("change", showLoad);
  $("record-file").addEventListener("change", uploadRecord);
  $("tableau").addEventListener("change", showComposition);
  $("system").addEventListener("input", offerMethods);
  for (const radio of document.querySelectorAll("input[name=source]")) radio.addEventListener("change", showSource);
  $("job-form").addEventListener("submit", submit);
  $("cancel").addEventListener("click", () => api(`/v1/jobs/${$("job-id").textContent}/cancel`, { method: "POST" }));
  $("refresh").addEventListener("click", refreshJobs);
  $("token-form").addEventListener("submit", useToken);
  $("downloads").addEventListener("click", download);
}

async function load() {
  [state.models, state.methods, state.structureMethods, state.compositions, state.examples] = await Promise.all(
    [getJSON("/v1/models"), getJSON("/v1/methods"), getJSON("/v1/structure_methods"), getJSON("/v1/compositions"),
      getJSON("/static/examples.json")]);
  for (const select of ["model", "method", "composition", "example"]) $(select).replaceChildren();
  for (const model of state.models) option($("model"), model.name, model.name);
  state.springs = editingSprings();
  fillMethods();
  for (const c of state.compositions) {
    option($("composition"), c.name, c.name === "none" ? "none (order 2)" : `${c.name} (order ${c.order}, ${c.stages} stages)`);
  }
  state.examples.systems.forEach((example, i) => option($("example"), i, example.label));
  $("method").value = offeredMethods().some((m) => m.name === "3s") ? "3s" : offeredMethods()[0].name;
  showMethod();
  showSource();
  document.body.dataset.ready = "true";
  refreshJobs();
}

function loadPage() {
  load().catch((error) => {
    if (!(error instanceof NeedsToken)) showErrors([{ loc: null, msg: `the page could not start: ${error.message}` }]);
  });
}

wire();
loadPage();
