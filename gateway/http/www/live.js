// SPDX-License-Identifier: MIT
// drgatewayd console: the live stream every page of one browser shares
// (a SharedWorker). A browser opens at most six connections to a host;
// a live page that held its own event stream held one of them for its
// life, so the seventh tab found none (issue 33). Here one stream,
// /api/v1/events?robots=A,B&overview=1, carries what all the pages need
// (the union of what they ask), reopened when that changes; each page
// gets the events of its robots, and on joining what is known so far.
// Messages to a page: {type: "overview" | "status" | "values" | "state"}.
"use strict";

var pages = [], es = null, key = "";
var known = { overview: null, status: {}, values: {} };

function want() {
  var robots = {}, overview = false;
  pages.forEach(function (p) {
    p.robots.forEach(function (r) { robots[r] = true; });
    overview = overview || p.overview;
  });
  return { robots: Object.keys(robots).sort(), overview: overview };
}

function send(filter, msg) {
  pages.forEach(function (p) { if (filter(p)) p.port.postMessage(msg); });
}

function open() {
  var w = want(), k = w.robots.join(",") + "|" + w.overview;
  if (k === key && es) return;
  key = k;
  if (es) es.close();
  es = null;
  known = { overview: null, status: {}, values: {} };
  if (!w.robots.length && !w.overview) return;
  var q = [];
  if (w.robots.length) q.push("robots=" + w.robots.map(encodeURIComponent).join(","));
  if (w.overview) q.push("overview=1");
  es = new EventSource("/api/v1/events?" + q.join("&"));
  es.addEventListener("overview", function (e) {
    known.overview = JSON.parse(e.data);
    send(function (p) { return p.overview; }, { type: "overview", data: known.overview });
  });
  es.addEventListener("status", function (e) {
    var d = JSON.parse(e.data);
    known.status[d.name] = d;
    send(function (p) { return p.robots.indexOf(d.name) >= 0; }, { type: "status", data: d });
  });
  es.addEventListener("values", function (e) {
    var d = JSON.parse(e.data), all = known.values[d.robot] || (known.values[d.robot] = {});
    Object.keys(d.values).forEach(function (k) { all[k] = d.values[k]; });
    send(function (p) { return p.robots.indexOf(d.robot) >= 0; }, { type: "values", robot: d.robot, values: d.values });
  });
  es.onopen = function () { send(function () { return true; }, { type: "state", state: "live" }); };
  es.onerror = function () {
    send(function () { return true; }, { type: "state", state: "stale", why: "event stream interrupted: reconnecting" });
  };
}

// What a page that joins an open stream would otherwise wait for.
function catchUp(p) {
  if (p.overview && known.overview) p.port.postMessage({ type: "overview", data: known.overview });
  p.robots.forEach(function (r) {
    if (known.status[r]) p.port.postMessage({ type: "status", data: known.status[r] });
    if (known.values[r]) p.port.postMessage({ type: "values", robot: r, values: known.values[r] });
  });
  if (es && es.readyState === 1) p.port.postMessage({ type: "state", state: "live" });
}

function drop(p) {
  var i = pages.indexOf(p);
  if (i >= 0) pages.splice(i, 1);
}

self.onconnect = function (e) {
  var p = { port: e.ports[0], robots: [], overview: false, seen: Date.now() };
  pages.push(p);
  p.port.onmessage = function (m) {
    var d = m.data || {};
    p.seen = Date.now();
    if (d.type === "subscribe") {
      p.robots = (d.robots || []).map(String);
      p.overview = !!d.overview;
      open();
      catchUp(p);
    } else if (d.type === "bye") {
      drop(p);
      open();
    }
  };
  p.port.start();
};

// A page that went without saying so (a crash, a killed tab) stops
// pinging: after 30 s its robots leave the stream.
setInterval(function () {
  var now = Date.now();
  pages.filter(function (p) { return now - p.seen > 30000; }).forEach(drop);
  open();
}, 5000);
