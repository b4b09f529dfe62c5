// The lensfarm dashboard: plain ES module, no framework and no build step. It polls the
// coordinator's /api (docs/dashboard.md) about once a second, with the token (client or viewer)
// from session storage in an Authorization header; images and downloads are fetched the same way and
// shown or saved through object URLs, so the token never appears in a URL.

const $ = (selector) => document.querySelector(selector);
const TOKEN_KEY = "lensfarm.token";
const POLL_MS = 1000;
const SNAPSHOT_SIDE = 512;

let route = { view: "overview" };
let shown = { jobId: null, version: -1, ev: null, url: null };  // the snapshot on the page
let evChoice = null;  // null: the scene's exposure; a number: the slider's
let lastJob = null;
let pollTimer = null;
// X-Lensfarm-Access: "full" (every action), "own" (a person who submits: actions on their own
// jobs), "read" (the viewer token or a viewer); X-Lensfarm-User: the person signed in, if any.
let access = "full";
let user = null;
let allJobs = [];  // the last job list, for the dependency graph
let capEditedFor = null;  // the job whose Max workers field a person is editing

// ---- talking to the coordinator --------------------------------------------------------------

class Unauthorized extends Error {}

function authHeaders() {
  const token = sessionStorage.getItem(TOKEN_KEY);
  return token ? { Authorization: `Bearer ${token}` } : {};
}

async function api(path, options = {}) {
  const response = await fetch(path, { ...options, headers: { ...authHeaders(), ...(options.headers || {}) } });
  if (response.status === 401) throw new Unauthorized((await response.json()).error || "unauthorized");
  const granted = response.headers.get("X-Lensfarm-Access");
  if (granted) { access = granted; user = response.headers.get("X-Lensfarm-User"); }
  if (!response.ok) {
    let message = `${response.status} ${response.statusText}`;
    try {
      const error = (await response.json()).error;  // /api: a text; /api/v1: {code, status, message}
      message = (error && error.message) || error || message;
    } catch (_) { /* not JSON */ }
    throw new Error(message);
  }
  return response;
}
// The actions go through the HTTP API (/api/v1, docs/api.md), which checks the person's role.
const v1 = async (method, path, body) =>
  (await api(`/api/v1/jobs/${path}`, { method, headers: { "Content-Type": "application/json" },
    body: body === undefined ? undefined : JSON.stringify(body) })).json();
const mayActOn = (job) => access === "full" || (access === "own" && job.owner === user);
const getJson = async (path) => (await api(path)).json();

// ---- formatting ------------------------------------------------------------------------------

function fmtCount(n) {
  if (!isFinite(n)) return "–";
  const units = [[1e12, "T"], [1e9, "G"], [1e6, "M"], [1e3, "k"]];
  for (const [scale, suffix] of units) if (Math.abs(n) >= scale) return `${(n / scale).toFixed(n / scale >= 100 ? 0 : 2)} ${suffix}`;
  return `${Math.round(n)}`;
}
function fmtDuration(s) {
  if (!(s > 0)) return "–";
  if (s < 10) return `${s.toFixed(1)} s`;
  if (s < 60) return `${Math.round(s)} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${String(Math.round(s % 60)).padStart(2, "0")} s`;
  return `${Math.floor(s / 3600)} h ${String(Math.round((s % 3600) / 60)).padStart(2, "0")} min`;
}
// An estimate: "–" before any unit is summed; "unknown" once units are summed but the estimate
// cannot be computed (an image black so far: film/convergence.h); else a percentage.
function fmtError(e, unitsDone = 0) {
  if (e === null || e === undefined || e < 0) return unitsDone > 0 ? "unknown" : "–";
  return e >= 0.1 ? `${(100 * e).toFixed(1)} %` : `${(100 * e).toFixed(2)} %`;
}
const fmtEv = (ev) => `${ev >= 0 ? "+" : "−"}${Math.abs(ev).toFixed(2)} EV`;
const isTerminal = (state) => state === "done" || state === "cancelled" || state === "failed";

function el(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attributes)) {
    if (k === "class") node.className = v;
    else if (k === "dataset") Object.assign(node.dataset, v);
    else node.setAttribute(k, v);
  }
  for (const child of children) node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  return node;
}
// Puts `rows` into `tbody`, keeping every row and cell whose content did not change: the lists are
// refreshed every second, and a node replaced between a click's press and release loses the click
// (for a person and for WebDriver alike), so a job's link must be the same node from poll to poll.
function patchRows(tbody, rows) {
  rows.forEach((row, i) => {
    const old = tbody.children[i];
    if (!old || old.dataset.key !== row.dataset.key || old.cells.length !== row.cells.length) {
      if (old) old.replaceWith(row); else tbody.append(row);
      return;
    }
    Object.assign(old.dataset, row.dataset);
    [...row.cells].forEach((cell, c) => {
      const kept = old.cells[c];
      if (kept.innerHTML !== cell.innerHTML || kept.className !== cell.className || kept.title !== cell.title)
        kept.replaceWith(cell);
    });
  });
  while (tbody.children.length > rows.length) tbody.lastElementChild.remove();
}
const badge = (state) => el("span", { class: `badge state-${state}` }, state);
// Samples per pixel: "106 / 128", or "688" for a job that runs to a target error or a deadline
// (spp_total null: it has no cap of its own).
const sppText = (j) => (j.spp_total === null ? `${j.spp_done}` : `${j.spp_done} / ${j.spp_total}`);
// What the progress bar measures: the nearest of the job's stopping rules.
function progressBasis(j) {
  const rules = [];
  if (j.spp_total !== null) rules.push(`${j.spp_total} spp`);
  if (j.target_error > 0) rules.push(`error ${fmtError(j.target_error)}`);
  if (j.time_limit_seconds > 0) rules.push(`deadline ${fmtDuration(j.time_limit_seconds)}`);
  return rules.join(" or ");
}
// Time left, or "stalled" (with the reason as a tooltip) while no worker renders the job.
function timeLeft(j) {
  if (isTerminal(j.state)) return j.stop_reason || j.state;
  if (j.stalled_reason) return el("span", { class: "stalled", title: j.stalled_reason }, "stalled");
  return fmtDuration(j.remaining_seconds);
}
// The cross-worker audit's counts, "12 passed, 1 failed, 2 pending; 40 units rendered again", or
// "" while they are all 0 (no audit yet, or the audit is off).
function auditText(j) {
  const passed = j.audits_passed || 0, failed = j.audits_failed || 0, pending = j.audits_pending || 0;
  const rerendered = j.units_rerendered || 0;
  if (!(passed || failed || pending || rerendered)) return "";
  return `${passed} passed, ${failed} failed, ${pending} pending; ${rerendered} units rendered again`;
}
function progressBar(fraction) {
  const bar = el("div", { class: "progress small" }, el("div"));
  bar.firstChild.style.width = `${Math.min(100, 100 * fraction).toFixed(1)}%`;
  return bar;
}

// ---- views -----------------------------------------------------------------------------------

function show(view) {
  for (const id of ["login", "overview", "job"]) $(`#${id}`).hidden = id !== view;
}

async function renderOverview() {
  const [{ jobs: everyJob }, { workers }] = await Promise.all([getJson("/api/jobs"), getJson("/api/workers")]);
  $("#mine-label").hidden = !user;
  $("#user-name").textContent = user || "";
  const jobs = user && $("#mine").checked ? everyJob.filter((j) => j.owner === user) : everyJob;
  const jobRows = jobs.map((j) =>
    el("tr", { dataset: { key: j.id, job: j.id, state: j.state } },
      el("td", {}, el("a", { href: `#/job/${encodeURIComponent(j.id)}` }, j.id)),
      el("td", {}, `${j.scene} `, el("span", { class: "muted" }, `${j.width}×${j.height}`)),
      el("td", {}, badge(j.state), j.archived ? el("span", { class: "muted small" }, " archived") : "",
        j.owner ? el("div", { class: "muted small" }, j.owner) : ""),
      el("td", { class: "num" }, j.priority),
      el("td", { class: "progress-cell", title: `toward ${progressBasis(j)}` }, progressBar(j.progress),
        el("span", { class: "muted" }, `${sppText(j)} spp`)),
      el("td", { class: "num" }, isTerminal(j.state) ? "–" : fmtCount(j.samples_per_second)),
      el("td", { class: "num" }, fmtError(j.estimated_error, j.units_done)),
      el("td", { class: "num time-left" }, timeLeft(j))));
  patchRows($("#jobs tbody"), jobRows);
  $("#jobs-empty").hidden = jobs.length > 0;
  const gone = (w) => w.state === "lost" || w.state === "left";
  // A quarantined worker (the cross-worker audit) says so first, its state beside, the reason below.
  const workerState = (w) => w.quarantined
    ? [badge("quarantined"), el("span", { class: "muted" }, ` ${w.state}`),
       el("div", { class: "quarantine-reason small" }, w.quarantine_reason)]
    : [badge(w.state),
       gone(w) || w.state === "stale" ? el("span", { class: "muted" }, ` ${fmtDuration(w.seconds_in_state)}${gone(w) ? " ago" : " silent"}`) : "",
       w.state_reason ? el("div", { class: "muted small" }, w.state_reason) : ""];
  const workerRows = workers.map((w) =>
    el("tr", { dataset: { key: w.id, worker: w.id, state: w.quarantined ? "quarantined" : w.state } },
      el("td", {}, w.name || w.id, " ", el("span", { class: "muted" }, w.id)),
      el("td", { class: "num" }, w.cores),
      el("td", { class: "worker-state" }, ...workerState(w)),
      el("td", {}, w.current_job
        ? el("a", { href: `#/job/${encodeURIComponent(w.current_job)}` }, `${w.current_job} · unit ${w.current_unit ?? "–"}`)
        : el("span", { class: "muted" }, "–")),
      el("td", { class: "num" }, w.samples_per_second > 0 ? fmtCount(w.samples_per_second) : "–"),
      el("td", { class: "num" }, w.units_done),
      el("td", { class: "num" }, `${w.seconds_since_heartbeat.toFixed(1)} s ago`)));
  patchRows($("#workers tbody"), workerRows);
  $("#workers-empty").hidden = workers.length > 0;
}

function stat(term, value, id) {
  return [el("dt", {}, term), el("dd", id ? { id } : {}, value)];
}

async function renderJob(jobId) {
  const [job, { jobs }] = await Promise.all([getJson(`/api/jobs/${encodeURIComponent(jobId)}`), getJson("/api/jobs")]);
  allJobs = jobs;
  lastJob = job;
  $("#job-id").textContent = job.id;
  $("#job-scene").textContent = `${job.scene} · ${job.width}×${job.height}`;
  const state = $("#job-state");
  state.textContent = job.state;
  state.className = `badge state-${job.state}`;
  $("#job-progress-bar").style.width = `${Math.min(100, 100 * job.progress).toFixed(1)}%`;
  $("#job-progress").title = `${(100 * job.progress).toFixed(0)} % of the way to ${progressBasis(job)}`;
  const running = !isTerminal(job.state);
  const target = job.target_error > 0 ? ` (target ${fmtError(job.target_error)})` : "";
  const audit = auditText(job);
  $("#job-stats").replaceChildren(
    ...stat("Samples per pixel", sppText(job), "job-spp"),
    ...stat("Units", job.units_total === null ? `${job.units_done}` : `${job.units_done} / ${job.units_total}`),
    ...(job.frames_total > 0
      ? stat("Frames", `${job.frames_complete} / ${job.frames_total} complete` +
          (job.frames ? " " + job.frames.map(([n, done, total]) => (done === total ? "#" : done > 0 ? "+" : ".")).join("") : ""),
          "job-frames")
      : []),
    ...stat("Progress", `${(100 * job.progress).toFixed(0)} % toward ${progressBasis(job)}`, "job-progress-text"),
    ...stat("Samples/s", running ? fmtCount(job.samples_per_second) : "–"),
    ...stat("Estimated error", fmtError(job.estimated_error, job.units_done) + target, "job-error"),
    ...stat("Elapsed", fmtDuration(job.elapsed_seconds)),
    ...stat(running ? "Time left" : "Stopped", running ? timeLeft(job) : (job.stop_reason || job.error || job.state), "job-time-left"),
    ...stat("Workers busy", job.workers_busy),
    ...(job.owner ? stat("Owner", job.owner, "job-owner") : []),
    ...(job.archived ? stat("Archived", "final image kept; sensor and ledger freed", "job-archived") : []),
    ...(job.paused ? stat("Paused", "no unit is leased until it is resumed", "job-paused") : []),
    ...(job.waiting_for && job.waiting_for.length ? stat("Waits for", job.waiting_for.join("; "), "job-waiting") : []),
    ...(job.deadline_outlook ? stat("Deadline", job.deadline_outlook, "job-outlook") : []),
    ...(job.policy && job.policy.require_tags.length ? stat("Requires", job.policy.require_tags.join(", "), "job-requires") : []),
    ...(job.approved ? stat("Approved", "yes", "job-approved") : []),
    ...(job.stalled_reason ? stat("Stalled", job.stalled_reason, "job-stalled") : []),
    ...(audit ? stat("Audit", audit, "job-audit") : []));
  $("#job-priority").textContent = job.priority;
  const mayAct = running && mayActOn(job);
  $("#cancel").disabled = !mayAct;
  $("#delete").disabled = !mayActOn(job);
  $("#set-cap").disabled = $("#max-workers").disabled = !mayAct;
  // (what a person is typing there is not overwritten by the next refresh)
  if (capEditedFor !== job.id) $("#max-workers").value = job.policy && job.policy.max_workers ? job.policy.max_workers : "";
  // Pause and resume: one button, its label the action it takes (docs/farm.md "Scheduling").
  $("#pause").disabled = !mayAct;
  $("#pause").textContent = job.paused ? "Resume" : "Pause";
  $("#approve").disabled = !mayActOn(job) || job.approved;
  $("#priority-up").disabled = $("#priority-down").disabled = !mayAct;
  $("#effects").replaceChildren(...job.effects.map((e) => {
    const m = /^([^:]+): (on|off)(?: \((.*)\))?$/.exec(e);
    if (!m) return el("li", {}, e);
    return el("li", {}, el("span", { class: `tag ${m[2]}` }, m[2]), " ", el("strong", {}, m[1]),
      m[3] ? el("span", { class: "muted" }, ` — ${m[3]}`) : "");
  }));
  const events = job.events || [];
  $("#events-card").hidden = events.length === 0;
  $("#events").replaceChildren(...events.map((e) =>
    el("li", {}, el("span", { class: "muted" }, new Date(1000 * e.unix_seconds).toLocaleString()), " ", e.text)));
  drawErrorChart($("#error-chart"), job.error_history, job.target_error);
  drawDependencies(job);
  if (job.version !== shown.version || evChoice !== shown.ev || shown.jobId !== job.id) await loadSnapshot(job);
}

async function loadSnapshot(job) {
  const ev = evChoice;
  const query = new URLSearchParams({ max: String(SNAPSHOT_SIDE) });
  if (ev !== null) query.set("ev", String(ev));
  const response = await api(`/api/jobs/${encodeURIComponent(job.id)}/snapshot.png?${query}`);
  const blob = await response.blob();
  const bytes = new Uint8Array(await blob.arrayBuffer());
  let hash = 0x811c9dc5;  // FNV-1a of the PNG: changes whenever the image does
  for (const b of bytes) hash = Math.imul(hash ^ b, 0x01000193) >>> 0;
  const url = URL.createObjectURL(blob);
  const img = $("#snapshot");
  await new Promise((resolve) => { img.onload = resolve; img.onerror = resolve; img.src = url; });
  if (shown.url) URL.revokeObjectURL(shown.url);
  const spp = response.headers.get("X-Samples-Per-Pixel");
  const appliedEv = Number(response.headers.get("X-Ev"));
  shown = { jobId: job.id, version: Number(response.headers.get("X-Job-Version")), ev, url };
  Object.assign(img.dataset, { spp, hash: hash.toString(16), version: String(shown.version) });
  $("#snapshot-caption").textContent =
    `${response.headers.get("X-Width")}×${response.headers.get("X-Height")} preview at ${spp} spp, ` +
    `automatic exposure ${fmtEv(appliedEv)}`;
  if (ev === null) { $("#ev").value = String(appliedEv); $("#ev-value").textContent = fmtEv(appliedEv); }
}

// The estimated relative error against elapsed time, log-scaled, as plain SVG.
// The job's dependencies as a graph: the jobs it waits for (left, each with its condition) and the
// jobs waiting for it (right), an arrow from each it waits for; each node's colour its state, a
// dashed arrow a condition that does not hold yet; each node a link to that job.
function drawDependencies(job) {
  const svg = $("#deps");
  const idOf = (text) => text.split(":")[0];
  const conditionOf = (text) => text.includes(":") ? text.slice(text.indexOf(":") + 1) : "done";
  const byId = new Map(allJobs.map((j) => [j.id, j]));
  const upstream = ((job.policy && job.policy.after) || []).map((t) => ({ id: idOf(t), label: conditionOf(t),
    holds: !(job.waiting_for || []).some((w) => w.startsWith(idOf(t) + " ") || w.startsWith(idOf(t) + ":")) }));
  const downstream = allJobs.filter((j) => j.policy && (j.policy.after || []).some((t) => idOf(t) === job.id))
    .map((j) => ({ id: j.id, label: conditionOf(j.policy.after.find((t) => idOf(t) === job.id)),
      holds: !(j.waiting_for || []).length }));
  $("#deps-card").hidden = upstream.length === 0 && downstream.length === 0;
  if ($("#deps-card").hidden) return;
  const rows = Math.max(upstream.length, downstream.length, 1);
  const W = 480, H = 40 + 44 * rows, boxW = 120, boxH = 30;
  svg.setAttribute("viewBox", `0 0 ${W} ${H}`);
  const NS = "http://www.w3.org/2000/svg";
  const make = (tag, attrs, text) => {
    const node = document.createElementNS(NS, tag);
    for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
    if (text !== undefined) node.textContent = text;
    return node;
  };
  const node = (id, x, y, extra) => {
    const j = byId.get(id);
    const link = make("a", { href: `#/job/${encodeURIComponent(id)}`, class: `dep-node state-${j ? j.state : "gone"}`,
      "data-job": id });
    link.append(make("rect", { x: x - boxW / 2, y: y - boxH / 2, width: boxW, height: boxH, rx: 6 }),
      make("text", { x, y: y + 4, "text-anchor": "middle" }, `${id} · ${j ? j.state : "deleted"}${extra || ""}`));
    return link;
  };
  const yOf = (i, n) => 20 + (H - 40) * (n === 1 ? 0.5 : i / (n - 1));
  const parts = [make("defs", {}), node(job.id, W / 2, H / 2, "")];
  parts[0].innerHTML = '<marker id="arrow" viewBox="0 0 8 8" refX="8" refY="4" markerWidth="6" markerHeight="6" orient="auto"><path d="M0,0 L8,4 L0,8 z"/></marker>';
  const edge = (x1, y1, x2, y2, label, holds) => [
    make("line", { x1, y1, x2, y2, class: holds ? "dep-edge" : "dep-edge waiting", "marker-end": "url(#arrow)" }),
    make("text", { x: (x1 + x2) / 2, y: (y1 + y2) / 2 - 4, "text-anchor": "middle", class: "dep-label" }, label)];
  upstream.forEach((u, i) => {
    const y = yOf(i, upstream.length);
    parts.push(...edge(70 + boxW / 2 - 10, y, W / 2 - boxW / 2, H / 2, u.label, u.holds), node(u.id, 70, y, ""));
  });
  downstream.forEach((d, i) => {
    const y = yOf(i, downstream.length);
    parts.push(...edge(W / 2 + boxW / 2, H / 2, W - 70 - boxW / 2 + 10, y, d.label, d.holds), node(d.id, W - 70, y, ""));
  });
  svg.replaceChildren(...parts);
}

function drawErrorChart(svg, history, target) {
  // Only positive, finite errors have a place on a log axis (a 0 would make the grid endless).
  const points = history.filter((p) => p.error > 0 && isFinite(p.error) && isFinite(p.t));
  const NS = "http://www.w3.org/2000/svg";
  const W = 480, H = 240, left = 58, right = 14, top = 12, bottom = 40;
  const node = (tag, attributes, text) => {
    const n = document.createElementNS(NS, tag);
    for (const [k, v] of Object.entries(attributes)) n.setAttribute(k, v);
    if (text !== undefined) n.textContent = text;
    return n;
  };
  const children = [];
  if (!points.length) {
    children.push(node("text", { x: W / 2, y: H / 2, "text-anchor": "middle", class: "chart-empty" },
      "no estimate yet (it needs two units)"));
    svg.replaceChildren(...children);
    return;
  }
  const errors = points.map((p) => p.error).concat(target > 0 ? [target] : []);
  let lo = Math.floor(Math.log10(Math.min(...errors)) * 2) / 2, hi = Math.ceil(Math.log10(Math.max(...errors)) * 2) / 2;
  if (hi - lo < 0.5) { lo -= 0.25; hi += 0.25; }
  const tMax = Math.max(1, ...points.map((p) => p.t)) * 1.02;
  const x = (t) => left + (W - left - right) * (t / tMax);
  const y = (e) => top + (H - top - bottom) * (1 - (Math.log10(e) - lo) / (hi - lo));
  // Grid: decades and their 2 and 5, seconds at round steps.
  for (let d = Math.floor(lo); d <= Math.ceil(hi); ++d) {
    for (const m of hi - lo <= 1.5 ? [1, 1.5, 2, 3, 5, 7] : [1, 2, 5]) {
      const e = m * 10 ** d, l = Math.log10(e);
      if (l < lo - 1e-9 || l > hi + 1e-9) continue;
      children.push(node("line", { x1: left, x2: W - right, y1: y(e), y2: y(e), class: m === 1 ? "grid major" : "grid" }));
      children.push(node("text", { x: left - 6, y: y(e) + 4, "text-anchor": "end", class: "tick" }, fmtError(e)));
    }
  }
  const step = [1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 1800, 3600].find((s) => tMax / s <= 6) || 7200;
  for (let t = 0; t <= tMax; t += step) {
    children.push(node("line", { x1: x(t), x2: x(t), y1: top, y2: H - bottom, class: "grid" }));
    children.push(node("text", { x: x(t), y: H - bottom + 16, "text-anchor": "middle", class: "tick" }, t < 60 ? `${t} s` : fmtDuration(t)));
  }
  children.push(node("line", { x1: left, x2: left, y1: top, y2: H - bottom, class: "axis" }));
  children.push(node("line", { x1: left, x2: W - right, y1: H - bottom, y2: H - bottom, class: "axis" }));
  children.push(node("text", { x: (left + W - right) / 2, y: H - 6, "text-anchor": "middle", class: "label" }, "elapsed time"));
  if (target > 0) {
    children.push(node("line", { x1: left, x2: W - right, y1: y(target), y2: y(target), class: "target" }));
    children.push(node("text", { x: W - right - 4, y: y(target) - 5, "text-anchor": "end", class: "tick target-label" }, "target"));
  }
  const path = points.map((p, i) => `${i ? "L" : "M"}${x(p.t).toFixed(1)},${y(p.error).toFixed(1)}`).join(" ");
  children.push(node("path", { d: path, class: "curve" }));
  const last = points[points.length - 1];
  children.push(node("circle", { cx: x(last.t), cy: y(last.error), r: 3.5, class: "dot" }));
  children.push(node("text", { x: Math.min(x(last.t) + 6, W - right - 50), y: y(last.error) - 8, class: "tick value" }, fmtError(last.error)));
  svg.dataset.points = String(points.length);
  svg.replaceChildren(...children);
}

// ---- downloads: fetched with the token, saved through a blob link ----------------------------

async function download(kind) {
  if (!lastJob) return;
  const query = kind === "png" && evChoice !== null ? `?ev=${evChoice}` : "";
  try {
    const blob = await (await api(`/api/jobs/${encodeURIComponent(lastJob.id)}/image.${kind}${query}`)).blob();
    const url = URL.createObjectURL(blob);
    const link = el("a", { href: url, download: `${lastJob.id}.${kind}` });
    document.body.append(link);
    link.click();
    link.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  } catch (e) {
    report(e);
  }
}

// ---- the loop --------------------------------------------------------------------------------

function report(e) {
  if (e instanceof Unauthorized) {
    show("login");
    $("#login-error").textContent = sessionStorage.getItem(TOKEN_KEY)
      ? `The coordinator refused the token (${e.message}).` : "";
    $("#forget-token").hidden = true;
    $("#connection").textContent = "";
    return;
  }
  const target = route.view === "job" ? $("#job-message") : null;
  if (target) target.textContent = e.message;
  $("#connection").textContent = `⚠ ${e.message}`;
  $("#connection").className = "connection bad";
}

// One poll at a time: a poll asked for while one runs starts right after it.
let polling = false, pollAgain = false;
async function poll() {
  clearTimeout(pollTimer);
  if (polling) { pollAgain = true; return; }
  polling = true;
  let authorized = true;
  try {
    if (route.view === "job") await renderJob(route.jobId);
    else await renderOverview();
    show(route.view);
    $("#forget-token").hidden = !sessionStorage.getItem(TOKEN_KEY);
    $("#read-only").hidden = access !== "read";
    $("#connection").textContent = `updated ${new Date().toLocaleTimeString()}`;
    $("#connection").className = "connection";
    if (route.view === "job") $("#job-message").textContent = "";
  } catch (e) {
    report(e);
    authorized = !(e instanceof Unauthorized);
  } finally {
    polling = false;
  }
  if (pollAgain) { pollAgain = false; return poll(); }
  if (authorized) pollTimer = setTimeout(poll, POLL_MS);  // else wait for a token
}

function onRoute() {
  const m = /^#\/job\/(.+)$/.exec(location.hash);
  route = m ? { view: "job", jobId: decodeURIComponent(m[1]) } : { view: "overview" };
  if (route.view === "job" && shown.jobId !== route.jobId) { evChoice = null; shown.version = -1; lastJob = null; }
  poll();
}

$("#token-form").addEventListener("submit", (event) => {
  event.preventDefault();
  const token = $("#token").value.trim();
  if (!token) { $("#login-error").textContent = "Paste a token first."; return; }
  sessionStorage.setItem(TOKEN_KEY, token);
  $("#token").value = "";
  $("#login-error").textContent = "Checking…";
  poll();
});
$("#forget-token").addEventListener("click", () => { sessionStorage.removeItem(TOKEN_KEY); poll(); });
$("#ev").addEventListener("input", () => {
  evChoice = Number($("#ev").value);
  $("#ev-value").textContent = fmtEv(evChoice);
});
$("#ev").addEventListener("change", () => poll());
$("#ev-auto").addEventListener("click", () => { evChoice = null; poll(); });
$("#cancel").addEventListener("click", async () => {
  if (!lastJob) return;
  try { await v1("POST", `${encodeURIComponent(lastJob.id)}/cancel`); } catch (e) { report(e); }
  poll();
});
$("#delete").addEventListener("click", async () => {
  if (!lastJob || !confirm(`Delete ${lastJob.id} for good? Its image and files are removed.`)) return;
  try {
    await v1("DELETE", `${encodeURIComponent(lastJob.id)}?force=true`);
    location.hash = "#/";
  } catch (e) { report(e); }
  poll();
});
$("#max-workers").addEventListener("input", () => { capEditedFor = lastJob && lastJob.id; });
$("#set-cap").addEventListener("click", async () => {
  if (!lastJob) return;
  const cap = Number($("#max-workers").value);
  try { await v1("PATCH", encodeURIComponent(lastJob.id), { max_workers: cap }); } catch (e) { report(e); }
  capEditedFor = null;
  poll();
});
$("#mine").addEventListener("change", () => poll());
$("#pause").addEventListener("click", async () => {
  if (!lastJob) return;
  const action = lastJob.paused ? "resume" : "pause";
  try { await v1("POST", `${encodeURIComponent(lastJob.id)}/${action}`); } catch (e) { report(e); }
  poll();
});
$("#approve").addEventListener("click", async () => {
  if (!lastJob) return;
  try { await v1("POST", `${encodeURIComponent(lastJob.id)}/approve`); } catch (e) { report(e); }
  poll();
});
for (const [id, delta] of [["#priority-up", 1], ["#priority-down", -1]]) {
  $(id).addEventListener("click", async () => {
    if (!lastJob) return;
    try { await v1("PATCH", encodeURIComponent(lastJob.id), { priority: lastJob.priority + delta }); }
    catch (e) { report(e); }
    poll();
  });
}
$("#download-exr").addEventListener("click", () => download("exr"));
$("#download-png").addEventListener("click", () => download("png"));
window.addEventListener("hashchange", onRoute);
onRoute();
