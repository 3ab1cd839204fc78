// SPDX-License-Identifier: MIT
// drgatewayd console: the overview (/) and the robot page (/robot/NAME).
// Plain JavaScript, no framework and nothing loaded from elsewhere (a
// plant network has no internet). Read-only: it only GETs the JSON API
// (docs/http.md). Text from the gateway goes into the page as text
// (textContent), never as markup.
"use strict";

(function () {
  // ---- helpers -------------------------------------------------------------

  function $(id) { return document.getElementById(id); }

  // el("td", {class: "v", "data-path": p}, "text", child...)
  function el(tag, attrs) {
    var e = document.createElement(tag);
    if (attrs) {
      Object.keys(attrs).forEach(function (k) {
        if (attrs[k] === null || attrs[k] === undefined) return;
        if (k === "class") e.className = attrs[k];
        else if (k === "text") e.textContent = attrs[k];
        else e.setAttribute(k, attrs[k]);
      });
    }
    for (var i = 2; i < arguments.length; i++) {
      var c = arguments[i];
      if (c === null || c === undefined) continue;
      e.appendChild(typeof c === "object" ? c : document.createTextNode(String(c)));
    }
    return e;
  }

  // Set text only when it changed (no layout work for what stays the same).
  function setText(node, text) {
    text = text === null || text === undefined ? "" : String(text);
    if (node && node.textContent !== text) node.textContent = text;
  }

  // An address of this gateway: from the page's origin, which has no
  // user and password in it even when the address typed had them
  // (http://user:pw@host/): fetch() refuses a URL made from such a page's
  // address, and the page stayed at "no answer" (issue 33).
  function abs(path) {
    return location.origin + path;
  }

  function getJSON(url) {
    return fetch(abs(url), { cache: "no-store", headers: { Accept: "application/json" } })
      .then(function (r) {
        if (!r.ok) {
          return r.text().then(function (t) {
            var err = new Error(url + ": HTTP " + r.status + (t ? ": " + t.trim().slice(0, 200) : ""));
            err.status = r.status;
            throw err;
          });
        }
        return r.json();
      });
  }

  function live(state, title) {
    var n = $("live");
    if (!n) return;
    n.setAttribute("data-state", state);
    setText(n, state === "live" ? "live" : state === "stale" ? "no answer" : "connecting");
    if (title) n.title = title;
  }

  function duration(s) {
    if (typeof s !== "number") return "-";
    var d = Math.floor(s / 86400), h = Math.floor(s % 86400 / 3600), m = Math.floor(s % 3600 / 60);
    var sec = Math.floor(s % 60);
    if (d) return d + "d " + h + "h " + m + "m";
    if (h) return h + "h " + m + "m " + sec + "s";
    if (m) return m + "m " + sec + "s";
    return sec + "s";
  }

  function ms(v) {
    if (typeof v !== "number") return "-";
    if (v < 1000) return v + " ms";
    if (v < 60000) return (v / 1000).toFixed(1) + " s";
    return duration(v / 1000);
  }

  function hex(v, digits) {
    var s = Number(v).toString(16).toUpperCase();
    while (s.length < digits) s = "0" + s;
    return "0x" + s;
  }

  // The cause in words as the log says it, then the status block's
  // last_error code (IR 12): "CIP 0x01/0x0106 ownership conflict (0x0106)",
  // "connection refused (0x000F)"; "-" when there was none.
  function lastError(e) {
    if (!e || !e.code) return "-";
    return e.text ? e.text + " (" + hex(e.code, 4) + ")" : hex(e.code, 4);
  }

  function clock(t) {
    if (!t) return "";
    var m = /T(\d\d:\d\d:\d\d(?:\.\d+)?)/.exec(t);
    return m ? m[1] : String(t);
  }

  function lastWrite(w) {
    if (!w) return "-";
    var f = (w.fields || []).join(", ");
    if (w.more) f += " and " + w.more + " more";
    return clock(w.time) + " " + (w.client || "?") + (f ? ": " + f : "");
  }

  function badge(node, state) {
    state = state || "unknown";
    var cls = "badge " + state.replace(/ /g, "-");
    if (node.className !== cls) node.className = cls;
    setText(node, state);
  }

  // "10.0.0.5:44818"
  function address(r) {
    return r.host ? r.host + ":" + r.tcp_port : "-";
  }

  // "1 (also 0, 255)": the unit ID a PLC names the robot by
  function unitText(r) {
    var m = r.sides && r.sides.modbus;
    if (!m) return "-";
    var al = m.unit_id_aliases || [];
    return m.unit_id + (al.length ? " (also " + al.join(", ") + ")" : "");
  }

  // The robot's state and servo, and whether they are the robot's now:
  // "never linked" (zeros, not the robot's), "stale" (older than the
  // connection timeout).
  function staleWord(r) {
    return !r.ever_linked ? "never linked" : r.values_stale ? "stale" : "";
  }

  function robotState(r) {
    if (!r.robot_state) return "-";
    return r.robot_state.name + " (" + r.robot_state.value + ")";
  }

  function servo(r) {
    return r.servo_on === null || r.servo_on === undefined ? "-" : r.servo_on ? "on" : "off";
  }

  function setStale(node, text, stale) {
    setText(node, text + (stale ? " (" + stale + ")" : ""));
    node.classList.toggle("stale", !!stale);
  }

  function age(r) {
    return r.age_ms === null ? "never" : ms(r.age_ms);
  }

  // ---- the live stream ----------------------------------------------------------
  // One stream for every page of the browser, through the pages' shared
  // worker (static/live.js); a browser without SharedWorker opens its own
  // (the same events). sub: {robots: [...], overview: bool}; on: the
  // handlers overview(data), status(robot), values(robot, values),
  // state(state, why).
  function liveStream(sub, on) {
    function deliver(m) {
      if (m.type === "overview" && on.overview) on.overview(m.data);
      else if (m.type === "status" && on.status) on.status(m.data);
      else if (m.type === "values" && on.values) on.values(m.robot, m.values);
      else if (m.type === "state" && on.state) on.state(m.state, m.why);
    }
    if (window.SharedWorker) {
      try {
        var port = new SharedWorker(abs("/static/live.js")).port;
        port.onmessage = function (e) { deliver(e.data || {}); };
        port.start();
        port.postMessage({ type: "subscribe", robots: sub.robots || [], overview: !!sub.overview });
        setInterval(function () { port.postMessage({ type: "ping" }); }, 5000);
        window.addEventListener("pagehide", function () { port.postMessage({ type: "bye" }); });
        return;
      } catch (e) { /* a browser that refuses it: a stream of its own */ }
    }
    if (!window.EventSource) return;
    var q = [];
    if ((sub.robots || []).length) q.push("robots=" + sub.robots.map(encodeURIComponent).join(","));
    if (sub.overview) q.push("overview=1");
    var es = new EventSource(abs("/api/v1/events?" + q.join("&")));
    es.addEventListener("overview", function (e) { deliver({ type: "overview", data: JSON.parse(e.data) }); });
    es.addEventListener("status", function (e) { deliver({ type: "status", data: JSON.parse(e.data) }); });
    es.addEventListener("values", function (e) {
      var d = JSON.parse(e.data);
      deliver({ type: "values", robot: d.robot, values: d.values });
    });
    es.onopen = function () { deliver({ type: "state", state: "live" }); };
    es.onerror = function () { deliver({ type: "state", state: "stale", why: "event stream interrupted: reconnecting" }); };
  }

  // ---- a side's report, whatever its members ---------------------------------
  // Each side writes its own object into /api/v1/status "sides"; shown as
  // tables (arrays of objects), nested blocks and name/value lists, with
  // levels as lamps and yes/no as badges.

  function sideValue(key, v) {
    if (typeof v === "boolean") {
      if (key === "level") return el("span", null, el("span", { class: "led" + (v ? " on" : "") }), v ? "1" : "0");
      return el("span", { class: "badge " + (v ? "yes" : "no") }, v ? "yes" : "no");
    }
    if (key === "level" && typeof v === "number")
      return el("span", null, el("span", { class: "led" + (v ? " on" : "") }), String(v));
    if (v === null || v === undefined) return "-";
    if (Array.isArray(v)) return v.map(function (x) { return typeof x === "object" ? JSON.stringify(x) : String(x); }).join(", ");
    if (typeof v === "object") return JSON.stringify(v);
    return String(v);
  }

  function sideTable(key, rows) {
    var cols = [];
    rows.forEach(function (r) {
      Object.keys(r).forEach(function (k) { if (cols.indexOf(k) < 0) cols.push(k); });
    });
    var head = el("tr");
    cols.forEach(function (c) { head.appendChild(el("th", null, c.replace(/_/g, " "))); });
    var body = el("tbody");
    rows.forEach(function (r) {
      var tr = el("tr");
      cols.forEach(function (c) {
        var v = r[c];
        tr.appendChild(el("td", { class: typeof v === "number" ? "num" : "mono", "data-col": c }, sideValue(c, v)));
      });
      body.appendChild(tr);
    });
    return el("table", { class: "grid", "data-list": key }, el("thead", null, head), body);
  }

  function renderSide(box, obj, depth) {
    var kv = el("dl", { class: "kv" }), any = false, out = document.createDocumentFragment();
    out.appendChild(kv);
    Object.keys(obj).forEach(function (k) {
      var v = obj[k];
      if (Array.isArray(v) && v.length && typeof v[0] === "object") {
        out.appendChild(el("h3", null, k.replace(/_/g, " ") + " (" + v.length + ")"));
        out.appendChild(sideTable(k, v));
      } else if (v && typeof v === "object" && !Array.isArray(v) && depth < 2) {
        out.appendChild(el("h3", null, k.replace(/_/g, " ")));
        var sub = el("div", { "data-block": k });
        renderSide(sub, v, depth + 1);
        out.appendChild(sub);
      } else if (Array.isArray(v) && !v.length) {
        kv.appendChild(el("dt", null, k.replace(/_/g, " ")));
        kv.appendChild(el("dd", { "data-key": k }, "none"));
        any = true;
      } else {
        kv.appendChild(el("dt", null, k.replace(/_/g, " ")));
        kv.appendChild(el("dd", { "data-key": k }, sideValue(k, v)));
        any = true;
      }
    });
    if (!any) out.removeChild(kv);
    box.textContent = "";
    box.appendChild(out);
  }

  // ---- overview ----------------------------------------------------------------

  var robotRows = {};

  function robotRow(name) {
    if (robotRows[name]) return robotRows[name];
    var cells = {};
    var tr = el("tr", { "data-robot": name });
    function cell(key, cls) {
      var td = el("td", { class: cls || null, "data-field": key });
      tr.appendChild(td);
      cells[key] = td;
      return td;
    }
    cell("name").appendChild(el("a", { href: "/robot/" + encodeURIComponent(name) }, name));
    cells.badge = el("span", { class: "badge" });
    cell("link").appendChild(cells.badge);
    cell("reason", "reason");
    cell("address", "mono");
    cell("unit", "num");
    cell("robot_state", "mono");
    cell("servo");
    cell("rpi", "num");
    cell("age", "num");
    cell("rx", "num");
    cell("lost", "num");
    cell("last_error", "mono");
    cell("last_write", "mono");
    robotRows[name] = { tr: tr, cells: cells };
    return robotRows[name];
  }

  // A connection's state: established green, on its way amber, idle grey,
  // anything else (failed, timed out, refused) red.
  function connClass(st) {
    if (/^(connected|established|open|up)$/.test(st)) return "ok";
    if (/pend|connecting|opening|closing/.test(st)) return "connecting";
    if (/^(idle|none|closed|off)$/.test(st)) return "idle";
    return "down";
  }

  function renderRobots(robots) {
    var body = $("robots").tBodies[0], seen = {};
    var conns = document.createDocumentFragment();
    robots.forEach(function (r, i) {
      var row = robotRow(r.name), c = row.cells;
      seen[r.name] = true;
      if (body.rows[i] !== row.tr) body.insertBefore(row.tr, body.rows[i] || null);
      badge(c.badge, r.state || r.link);
      c.link.setAttribute("data-state", r.link || "");
      c.link.setAttribute("data-ever", r.ever_linked ? "yes" : "no");
      setText(c.reason, r.link === "up" ? "" : (r.reason || ""));
      setText(c.address, address(r));
      setText(c.unit, unitText(r));
      setStale(c.robot_state, robotState(r), staleWord(r));
      setStale(c.servo, servo(r), r.ever_linked && r.values_stale ? "stale" : "");
      setText(c.rpi, typeof r.rpi_ms === "number" ? r.rpi_ms + " ms" : "-");
      setStale(c.age, age(r), r.ever_linked && !r.fresh ? "stale" : "");
      setText(c.rx, r.rx_packets);
      setText(c.lost, r.lost_packets);
      setText(c.last_error, lastError(r.last_error));
      setText(c.last_write, lastWrite(r.last_write));
      var line = el("div", { class: "conns", "data-robot": r.name }, el("strong", null, r.name));
      (r.connections || []).forEach(function (k) {
        var extra = Object.keys(k).filter(function (x) {
          return x !== "assembly" && x !== "name" && x !== "state";
        })
          .map(function (x) { return x.replace(/_packets$/, "") + " " + k[x]; }).join(", ");
        var st = String(k.state);
        line.appendChild(el("span", { class: "conn", "data-assembly": k.assembly },
          (k.name || k.assembly) + " ", el("span", { class: "badge " + connClass(st) }, st),
          extra ? " " + extra : ""));
      });
      conns.appendChild(line);
    });
    Object.keys(robotRows).forEach(function (n) {
      if (!seen[n]) { robotRows[n].tr.remove(); delete robotRows[n]; }
    });
    var box = $("connections");
    box.textContent = "";
    box.appendChild(el("h3", null, "Connections"));
    box.appendChild(conns);
    var up = robots.filter(function (r) { return r.link === "up"; }).length;
    setText($("robot-count"), up + " of " + robots.length + " linked");
  }

  function renderStatus(st) {
    setText($("gw-version"), st.version);
    setText($("gw-uptime"), duration(st.uptime_s));
    setText($("gw-config"), st.config ? st.config.file : "-");
    setText($("gw-generation"), st.config ? st.config.generation : "-");
    renderRobots(st.robots || []);
    var sides = st.sides || {}, other = {};
    ["modbus", "gpio", "mqtt"].forEach(function (k) {
      var box = $(k);
      if (sides[k]) renderSide(box, sides[k], 0);
      else { box.textContent = ""; box.appendChild(el("p", { class: "muted" }, k === "mqtt" || k === "gpio" ? "not configured" : "no report")); }
    });
    Object.keys(sides).forEach(function (k) { if (["modbus", "gpio", "mqtt"].indexOf(k) < 0) other[k] = sides[k]; });
    $("side-other").hidden = !Object.keys(other).length;
    if (Object.keys(other).length) renderSide($("other"), other, 0);
    if (st.log_dropped) setText($("foot-note"), st.log_dropped + " log events dropped");
  }

  var logSig = {};
  // The events' log (tbl "log", with the warnings box) or the writes'
  // ("writes"), the newest first; redrawn only when it changed.
  function renderLog(events, tbl) {
    tbl = tbl || "log";
    var warnOnly = tbl === "log" && $("log-warn").checked;
    var sig = events.length + "|" + (events.length ? events[events.length - 1].time + events[events.length - 1].text : "") + "|" + warnOnly;
    if (sig === logSig[tbl]) return;
    logSig[tbl] = sig;
    var body = $(tbl).tBodies[0], frag = document.createDocumentFragment(), shown = 0;
    for (var i = events.length - 1; i >= 0; i--) { // the newest first
      var e = events[i], lvl = String(e.level || "");
      if (warnOnly && !/warn|err|crit/.test(lvl)) continue;
      frag.appendChild(el("tr", { class: /err|crit/.test(lvl) ? "error" : /warn/.test(lvl) ? "warning" : null },
        el("td", null, String(e.time || "").replace("T", " ").replace("Z", "")),
        el("td", { class: "level" }, lvl), el("td", null, e.text)));
      shown++;
    }
    body.textContent = "";
    body.appendChild(frag);
    setText($(tbl + "-count"), shown + " of " + events.length + (tbl === "log" ? " events" : " writes") + ", the newest first");
  }

  function renderWrites(events) {
    renderLog(events, "writes");
  }

  // ---- Modbus requests (the Modbus side's request log) ------------------------

  var reqData = null;

  function exText(code, name) {
    return hex(code, 2) + (name ? " " + name : "");
  }

  function renderRequests() {
    var d = reqData;
    if (!d) return;
    $("requests-card").hidden = false;
    var q = $("req-filter").value.trim().toLowerCase(), exOnly = $("req-ex").checked;
    var all = [];
    (d.clients || []).forEach(function (c) {
      (c.log || []).forEach(function (e) { all.push({ c: c, e: e }); });
    });
    all.sort(function (a, b) { return a.e.age_ms - b.e.age_ms; }); // the newest first
    var body = $("requests").tBodies[0], frag = document.createDocumentFragment(), shown = 0;
    all.forEach(function (x) {
      var e = x.e, c = x.c;
      var result = e.ex ? "exception " + exText(e.ex, e.exception) : "ok";
      var fn = "FC " + e.fc + (e.function ? " " + e.function : "");
      var who = c.client + (c.transport === "rtu" ? " (RTU)" : c.connected ? "" : " (gone)");
      var key = (who + " " + fn + " " + e.addr + " unit " + e.unit + " " + result).toLowerCase();
      if ((exOnly && !e.ex) || (q && key.indexOf(q) < 0)) return;
      frag.appendChild(el("tr", { class: e.ex ? "error" : null, "data-client": c.client, "data-fc": e.fc,
        "data-addr": e.addr, "data-ex": e.ex },
        el("td", null, ms(e.age_ms) + " ago"), el("td", { class: "mono" }, who),
        el("td", { class: "num" }, e.unit), el("td", null, fn), el("td", { class: "num" }, e.addr),
        el("td", { class: "num" }, e.count), el("td", { class: e.ex ? "reason" : null }, result)));
      shown++;
    });
    body.textContent = "";
    body.appendChild(frag);
    setText($("req-count"), shown + " of " + all.length + " requests of " + (d.clients || []).length +
      " client" + ((d.clients || []).length === 1 ? "" : "s") + " (the last " + d.log_size + " of each), the newest first");
    var ex = d.exceptions || {}, box = $("req-exceptions");
    box.textContent = "";
    if ((ex.by_code || []).length) {
      box.appendChild(el("h3", null, "Exceptions by code"));
      box.appendChild(el("p", { class: "mono", id: "req-by-code" }, (ex.by_code || []).map(function (b) {
        return exText(b.code, b.name) + ": " + b.count;
      }).join(", ")));
      box.appendChild(el("h3", null, "Exceptions by address" + (ex.other ? " (" + ex.other + " more elsewhere)" : "")));
      box.appendChild(sideTable("by_address", (ex.by_address || []).map(function (p) {
        return { transport: p.transport, unit: p.unit, "function": "FC " + p.fc + (p["function"] ? " " + p["function"] : ""),
          address: p.addr, exception: exText(p.code, p.name), count: p.count, last: ms(p.last_age_ms) + " ago" };
      })));
    }
  }

  function overview() {
    var lastLog = 0, lastEvents = [], lastWrites = [], lastReq = 0, reqOn = true, lastStream = 0;
    // The status from the live stream (when it changed, at most twice a
    // second); polled while the stream brings nothing.
    liveStream({ overview: true }, {
      overview: function (st) { lastStream = Date.now(); renderStatus(st); live("live"); },
      state: function (state, why) { if (state !== "live") live("stale", why); }
    });
    function tick() {
      var now = Date.now(), jobs = [];
      if (now - lastStream > 3000) jobs.push(getJSON("/api/v1/status").then(renderStatus));
      if (reqOn && now - lastReq >= 1000) {
        lastReq = now;
        jobs.push(getJSON("/api/v1/modbus/requests").then(function (d) { reqData = d; renderRequests(); },
          function (e) { if (e.status === 404) reqOn = false; else throw e; }));
      }
      if (now - lastLog >= 2000) {
        jobs.push(getJSON("/api/v1/writes").then(function (ev) { lastWrites = ev || []; renderWrites(lastWrites); }));
      }
      if (now - lastLog >= 2000) {
        lastLog = now;
        jobs.push(getJSON("/api/v1/log").then(function (ev) { lastEvents = ev || []; renderLog(lastEvents); }));
      }
      Promise.all(jobs).then(function () { live("live"); }, function (e) { live("stale", String(e.message || e)); })
        .then(function () { setTimeout(tick, document.hidden ? 5000 : 500); });
    }
    $("log-warn").addEventListener("change", function () { renderLog(lastEvents); });
    $("req-filter").addEventListener("input", renderRequests);
    $("req-ex").addEventListener("change", renderRequests);
    tick();
  }

  // ---- robot page --------------------------------------------------------------

  var JOINTS = ["joint_state.position[1]", "joint_state.position[2]", "joint_state.position[3]",
    "joint_state.position[4]", "joint_state.position[5]", "joint_state.position[6]"];
  var COLORS = ["#1565c0", "#c62828", "#2e7d32", "#ef6c00", "#6a1b9a", "#00838f"];
  var TREND_MS = 30000;

  // "IR 200-201 30201 real cdab", "IR 1200 31201 int16 x10", "IR 100 30101 bit 2"
  // (a coil or discrete input needs no view: the table says it is a bit)
  function locText(l) {
    var a = l.table + " " + l.address + (l.count > 1 ? "-" + (l.address + l.count - 1) : "");
    var v = l.view === "bit" ? "" : l.view === "bits" ? "bit" : l.view.toUpperCase();
    if (l.order) v += " " + l.order;
    if (l.scale) v += " \u00d7" + l.scale + (l.saturate ? " saturated" : "");
    if (typeof l.bit === "number") v += " " + l.bit;
    if (l.half) v += " " + l.half + " half";
    return a + " " + l.ref + (v ? " " + v : "");
  }

  // Registers before bits, the default map before the robot's own.
  var TABLE_ORDER = { HR: 0, IR: 0, CO: 1, DI: 1 };
  function locOrder(a, b) {
    return (a.user ? 1 : 0) - (b.user ? 1 : 0) || TABLE_ORDER[a.table] - TABLE_ORDER[b.table] ||
      a.address - b.address;
  }

  function fieldValue(f, v) {
    if (v === undefined) return "";
    if (v === null) return "NaN";
    if (typeof v === "boolean") return v ? "1" : "0";
    if (f && f.enum && typeof v === "number") return (f.enum[v] || "?") + " (" + v + ")";
    return String(v);
  }

  var REF_PREFIX = { CO: 0, DI: 1, IR: 3, HR: 4 };

  function pad(n, w) {
    var s = String(n);
    while (s.length < w) s = "0" + s;
    return s;
  }

  // Every way a register of l can be asked for: "hr 2005", "42006",
  // "402006" (the 6-digit reference), per address it takes.
  function locTokens(l) {
    var out = [];
    for (var a = l.address; a < l.address + (l.count || 1); a++) {
      var p = REF_PREFIX[l.table];
      out.push(l.table.toLowerCase() + " " + a, String(p) + pad(a + 1, 4), String(p) + pad(a + 1, 5));
    }
    return out;
  }

  // A query that names one register ("HR 2005", "42006") matches that
  // register only; any other text, any part of the row.
  var EXACT = /^((hr|ir|co|di) ?\d+|\d{5,6})$/;
  function matches(key, q) {
    if (!q) return true;
    if (EXACT.test(q)) return key.indexOf("|" + q.replace(/^(hr|ir|co|di)(\d)/, "$1 $2") + "|") >= 0;
    return key.indexOf(q) >= 0;
  }

  function group(path) {
    var m = /^[a-z0-9_]+/.exec(path);
    return m ? m[0] : path;
  }

  function robotPage() {
    var name = decodeURIComponent(location.pathname.replace(/\/+$/, "").split("/").pop() || "");
    var base = "/api/v1/robots/" + encodeURIComponent(name);
    var rows = {}, fields = {}, values = {}, allRows = [], groups = [];
    var updates = 0, firstUpdate = 0, trend = [], drawQueued = false, lastStatus = null;
    document.title = name + " - drgatewayd console";
    setText($("robot-name"), name);
    $("api-values").href = base + "/values";
    $("api-map").href = base + "/map";
    $("map-csv").href = base + "/map.csv";
    $("map-csv").setAttribute("download", name + "-map.csv");

    function fail(msg) {
      var body = $("fields").tBodies[0];
      body.textContent = "";
      body.appendChild(el("tr", null, el("td", { colspan: 6, class: "reason", id: "page-error" }, msg)));
    }

    function build(map) {
      setText($("unit-id"), map.unit_id);
      setText($("word-order"), map.word_order);
      var body = $("fields").tBodies[0], frag = document.createDocumentFragment(), g = null;
      (map.fields || []).forEach(function (f) {
        var gname = group(f.path);
        if (!g || g.name !== gname) {
          g = { name: gname, tr: el("tr", { class: "group", "data-group": gname },
            el("td", { colspan: 6 }, gname + " ", el("span", { class: "muted" }, f.dir))), rows: [] };
          groups.push(g);
          frag.appendChild(g.tr);
        }
        var mb = el("td", { class: "mb" }), mbText = [];
        (f.modbus || []).slice().sort(locOrder).forEach(function (l) {
          var t = locText(l);
          mbText.push(t);
          mb.appendChild(el("span", { class: "loc" }, t, l.user ? el("span", { class: "tag user" }, "map") : null,
            l.writable ? el("span", { class: "tag rw" }, "rw") : null));
        });
        var v = el("td", { class: "v", "data-value": f.path });
        var tr = el("tr", { "data-path": f.path, title: f.help || null },
          el("td", { class: "path" }, f.path), v, el("td", { class: "unit" }, f.unit || ""),
          el("td", { class: "type" }, f.type), el("td", { class: "dir" }, f.dir), mb);
        var toks = [f.path, f.unit || "", f.type, f.dir].concat(mbText, f.enum || []);
        (f.modbus || []).forEach(function (l) {
          toks = toks.concat(locTokens(l));
          if (l.user) toks.push("map", "user map");
          if (l.writable) toks.push("rw", "writable");
        });
        var row = { tr: tr, v: v, key: ("|" + toks.join("|") + "|").toLowerCase(), group: g };
        rows[f.path] = row;
        fields[f.path] = f;
        allRows.push(row);
        g.rows.push(row);
        frag.appendChild(tr);
      });
      body.textContent = "";
      body.appendChild(frag);
      filter();
      userMap(map.fields || []);
    }

    // The robot's own map as blocks: consecutive elements of one field
    // in one view at consecutive addresses are one block.
    function userMap(fl) {
      var locs = [];
      fl.forEach(function (f) {
        (f.modbus || []).forEach(function (l) { if (l.user) locs.push({ l: l, path: f.path }); });
      });
      $("user-map-card").hidden = !locs.length;
      if (!locs.length) return;
      locs.sort(function (a, b) {
        return (a.l.table < b.l.table ? -1 : a.l.table > b.l.table ? 1 : 0) || a.l.address - b.l.address;
      });
      var blocks = [];
      locs.forEach(function (x) {
        var m = /^(.*)\[(\d+)\]$/.exec(x.path), base = m ? m[1] : x.path, idx = m ? Number(m[2]) : -1;
        var b = blocks[blocks.length - 1], end = b ? b.address + b.count : -1;
        if (b && b.table === x.l.table && b.view === x.l.view && b.base === base && idx === b.last + 1 &&
            (x.l.address === end || (x.l.view === "bits" && x.l.address <= end))) {
          b.last = idx;
          b.count = Math.max(b.count, x.l.address + x.l.count - b.address);
          return;
        }
        blocks.push({ table: x.l.table, address: x.l.address, count: x.l.count, view: x.l.view, base: base,
          first: idx, last: idx, path: x.path, writable: x.l.writable, l: x.l });
      });
      var body = $("user-map").tBodies[0];
      body.textContent = "";
      blocks.forEach(function (b) {
        var p = REF_PREFIX[b.table], lastA = b.address + b.count - 1;
        var fieldsText = b.first < 0 ? b.path : b.base + "[" + b.first + (b.last > b.first ? ".." + b.last : "") + "]";
        var v = locText(b.l).split(" ").slice(3).join(" ") || b.view;
        body.appendChild(el("tr", { "data-block": b.table + " " + b.address },
          el("td", null, b.table), el("td", { class: "num" }, b.address + (lastA > b.address ? "-" + lastA : "")),
          el("td", { class: "num" }, p + pad(b.address + 1, 4) + (lastA > b.address ? "-" + p + pad(lastA + 1, 4) : "")),
          el("td", { class: "mono" }, fieldsText), el("td", null, v), el("td", null, b.writable ? "rw" : "")));
      });
      setText($("user-map-count"), blocks.length + " block" + (blocks.length === 1 ? "" : "s"));
    }

    function filter() {
      var q = $("filter").value.trim().toLowerCase().replace(/\s+/g, " "), shown = 0;
      allRows.forEach(function (r) {
        var hide = !matches(r.key, q);
        if (r.tr.hidden !== hide) r.tr.hidden = hide;
        if (!hide) shown++;
      });
      groups.forEach(function (g) {
        var hide = !g.rows.some(function (r) { return !r.tr.hidden; });
        if (g.tr.hidden !== hide) g.tr.hidden = hide;
      });
      setText($("field-count"), q ? shown + " of " + allRows.length + " fields" : allRows.length + " fields");
    }

    function apply(vals) {
      var now = Date.now();
      Object.keys(vals).forEach(function (p) {
        var v = vals[p], old = values[p], row = rows[p];
        values[p] = v;
        if (!row) return;
        row.v.setAttribute("data-updated", now); // when the gateway last said it (tests read it)
        var t = fieldValue(fields[p], v);
        if (row.v.textContent === t) return;
        row.v.textContent = t;
        if (old !== undefined) { // highlight a change, not the first value
          // two classes with the same animation, in turn: a new class
          // restarts it without forcing a layout per changed value
          var odd = row.v.classList.contains("chg");
          row.v.classList.toggle("chg", !odd);
          row.v.classList.toggle("chg2", odd);
        }
      });
      if (values["io_state.robot_state"] !== undefined && lastStatus && lastStatus.ever_linked && !lastStatus.values_stale)
        setStale($("robot-state"), fieldValue(fields["io_state.robot_state"], values["io_state.robot_state"]), "");
      if (values["io_state.servo_on"] !== undefined && lastStatus && lastStatus.ever_linked && !lastStatus.values_stale)
        setStale($("servo"), values["io_state.servo_on"] ? "on" : "off", "");
      updates++;
      if (!firstUpdate) firstUpdate = now;
      var secs = (now - firstUpdate) / 1000;
      setText($("updates"), updates + (secs > 2 ? " (" + (updates / secs).toFixed(1) + "/s)" : ""));
      var pt = [now];
      JOINTS.forEach(function (j) { pt.push(typeof values[j] === "number" ? values[j] : NaN); });
      trend.push(pt);
      while (trend.length && trend[0][0] < now - TREND_MS) trend.shift();
      if (!drawQueued) { drawQueued = true; requestAnimationFrame(draw); }
    }

    function draw() {
      drawQueued = false;
      var c = $("trend"), w = c.clientWidth, h = c.clientHeight, dpr = window.devicePixelRatio || 1;
      if (c.width !== Math.round(w * dpr) || c.height !== Math.round(h * dpr)) {
        c.width = Math.round(w * dpr);
        c.height = Math.round(h * dpr);
      }
      var x = c.getContext("2d");
      x.setTransform(dpr, 0, 0, dpr, 0, 0);
      x.clearRect(0, 0, w, h);
      var lo = Infinity, hi = -Infinity;
      trend.forEach(function (p) {
        for (var i = 1; i < p.length; i++) if (isFinite(p[i])) { lo = Math.min(lo, p[i]); hi = Math.max(hi, p[i]); }
      });
      if (!isFinite(lo)) return;
      if (hi - lo < 1) { lo -= 0.5; hi += 0.5; }
      var pad = (hi - lo) * 0.08; lo -= pad; hi += pad;
      var left = 44, right = w - 6, top = 6, bottom = h - 16, now = Date.now();
      function X(t) { return left + (right - left) * (1 - (now - t) / TREND_MS); }
      function Y(v) { return bottom - (bottom - top) * (v - lo) / (hi - lo); }
      x.font = "10px sans-serif";
      x.fillStyle = "#78909c";
      x.strokeStyle = "#eceff1";
      x.lineWidth = 1;
      for (var k = 0; k <= 4; k++) {
        var v = lo + (hi - lo) * k / 4, y = Math.round(Y(v)) + 0.5;
        x.beginPath(); x.moveTo(left, y); x.lineTo(right, y); x.stroke();
        x.fillText(v.toFixed(Math.abs(hi - lo) < 10 ? 1 : 0), 2, y + 3);
      }
      for (var s = 0; s <= 30; s += 10) x.fillText("-" + s + " s", X(now - s * 1000) - (s ? 12 : 26), h - 3);
      for (var j = 0; j < JOINTS.length; j++) {
        x.strokeStyle = COLORS[j];
        x.lineWidth = 1.5;
        x.beginPath();
        var pen = false;
        trend.forEach(function (p) {
          if (!isFinite(p[j + 1])) { pen = false; return; }
          if (pen) x.lineTo(X(p[0]), Y(p[j + 1])); else x.moveTo(X(p[0]), Y(p[j + 1]));
          pen = true;
        });
        x.stroke();
      }
    }

    var legend = $("trend-legend");
    JOINTS.forEach(function (j, i) {
      legend.appendChild(el("span", null, el("i", { style: "background:" + COLORS[i] }), "J" + (i + 1) + " ",
        el("span", { "data-trend": j }, "")));
    });
    setInterval(function () { // the legend's numbers and a moving time axis when nothing changes
      JOINTS.forEach(function (j) {
        var n = legend.querySelector('[data-trend="' + j + '"]');
        setText(n, typeof values[j] === "number" ? values[j].toFixed(2) : "");
      });
      if (trend.length && !drawQueued) { drawQueued = true; requestAnimationFrame(draw); }
    }, 500);

    function status(r) {
      lastStatus = r;
      badge($("link"), r.state || r.link);
      setText($("address"), address(r));
      setText($("unit-id"), unitText(r));
      setText($("plan"), r.mode + ", " + String(r.layout).replace(/_/g, " "));
      setText($("serial"), r.originator_serial || "-");
      setStale($("robot-state"), robotState(r), staleWord(r));
      setStale($("servo"), servo(r), r.ever_linked && r.values_stale ? "stale" : "");
      var note = $("stale-note"), word = staleWord(r);
      note.hidden = !word;
      $("fields").classList.toggle("stale", !!word);
      setText(note, !r.ever_linked ? "Never linked: the values below are zeros the gateway started with, not the robot's." :
        r.values_stale ? "Stale: the values below are the last the robot sent, " + age(r) + " ago; its link is " + r.link + "." : "");
      setText($("reason"), r.link === "up" ? "" : (r.reason || ""));
      setText($("rpi"), typeof r.rpi_ms === "number" ? r.rpi_ms + " ms" : "-");
      setStale($("age"), age(r), r.ever_linked && !r.fresh ? "stale" : "");
      setText($("last-write"), lastWrite(r.last_write));
      setText($("last-error"), lastError(r.last_error));
      setText($("packets"), (r.rx_packets === undefined ? "-" : r.rx_packets) + " / " + (r.lost_packets === undefined ? "-" : r.lost_packets));
    }

    // Values: the live stream (the first event carries every value, then
    // what changed, a few times a second); while they do not come, the
    // values are polled instead.
    var lastValues = 0, streaming = false;
    function stream() {
      lastValues = Date.now(); // its first event carries every value
      liveStream({ robots: [name] }, {
        values: function (robot, vals) { lastValues = Date.now(); live("live"); apply(vals); },
        status: function (r) { status(r); },
        state: function (state, why) {
          streaming = state === "live";
          live(state === "live" ? "live" : "stale", why);
        }
      });
    }
    function poll() {
      getJSON(base).then(function (r) { status(r); if (!streaming) live("live"); },
        function (e) { live("stale", String(e.message || e)); })
        .then(function () { setTimeout(poll, document.hidden ? 5000 : 2000); });
    }
    // (nothing to ask while the stream brings values)
    function pollValues() {
      var job = Date.now() - lastValues > 1500 && !document.hidden ?
        getJSON(base + "/values").then(apply, function () {}) : Promise.resolve();
      job.then(function () { setTimeout(pollValues, 1000); });
    }

    $("filter").addEventListener("input", filter);

    // The raw registers, asked every two seconds while the box is open.
    function raw() {
      if (!$("raw").open) return;
      getJSON("/api/v1/modbus/registers/" + encodeURIComponent(name)).then(function (d) {
        var box = $("raw-tables"), frag = document.createDocumentFragment();
        Object.keys(d.tables || {}).forEach(function (t) {
          var body = el("tbody");
          d.tables[t].forEach(function (r) {
            var words = r.words ? r.words.map(function (w) { return w + " (" + hex(w, 4) + ")"; }).join(" ") :
              "exception " + hex(r.ex, 2);
            body.appendChild(el("tr", { "data-reg": t + " " + r.address },
              el("td", { class: "num" }, r.address + (r.count > 1 ? "-" + (r.address + r.count - 1) : "")),
              el("td", { class: "num" }, r.ref), el("td", { class: "mono" }, words),
              el("td", { class: "mono" }, r.name, r.user ? el("span", { class: "tag user" }, "map") : null)));
          });
          frag.appendChild(el("h3", null, t));
          frag.appendChild(el("div", { class: "wide", tabindex: "0" }, el("table", { class: "grid", "data-table": t },
            el("thead", null, el("tr", null, el("th", { class: "num" }, "address"), el("th", { class: "num" }, "reference"),
              el("th", null, "words"), el("th", null, "field"))), body)));
        });
        box.textContent = "";
        box.appendChild(frag);
      }, function (e) { setText($("raw-tables"), String(e.message || e)); })
        .then(function () { setTimeout(raw, 2000); });
    }
    $("raw").addEventListener("toggle", raw);
    Promise.all([getJSON(base + "/map"), getJSON(base)]).then(function (res) {
      build(res[0]);
      status(res[1]);
      stream();
      poll();
      pollValues();
    }, function (e) {
      live("stale");
      fail(e.status === 404 ? "no robot named \"" + name + "\" in this gateway" : String(e.message || e));
    });
  }

  // ---- configuration page --------------------------------------------------------

  function configPage() {
    fetch(abs("/api/v1/config"), { cache: "no-store" }).then(function (r) {
      if (!r.ok) throw new Error("/api/v1/config: HTTP " + r.status);
      return r.text();
    }).then(function (t) { setText($("config"), t); live("live"); },
      function (e) { live("stale", String(e.message || e)); });
  }

  document.addEventListener("DOMContentLoaded", function () {
    var page = document.body.getAttribute("data-page");
    if (page === "overview") overview();
    else if (page === "robot") robotPage();
    else if (page === "config") configPage();
  });
})();
