# SPDX-License-Identifier: MIT
"""The Sparkplug 3.0 edge-node rules that can be checked from the wire,
applied to every message of a recorded session (docs/mqtt.md "Tests").

The Eclipse Sparkplug TCK cannot run here (it is not on the reachable
registries); these are the rules of its edge-node tests (SessionEstablishment,
SendData, the bdSeq and sequence checks) that need nothing but the messages
a host receives, each with the QoS and retain flag it was published with
(tests/tahu/host.js subscribes with MQTT 5 retain-as-published at QoS 2).
Each rule has a short name, used in the violations:

  qos-retain      NBIRTH, DBIRTH, NDATA, DDATA, DDEATH: QoS 0, not retained;
                  NDEATH: QoS 1, not retained
  timestamp       NBIRTH, DBIRTH, NDATA, DDATA, DDEATH carry a payload
                  timestamp; every metric of NBIRTH, DBIRTH, NDATA and
                  DDATA carries one (tck-id-payloads-name-birth-data-requirement)
  nbirth          NBIRTH: seq 0, a bdSeq metric (Int64), Node Control/Rebirth
                  (Boolean) with no alias
                  (tck-id-operational-behavior-data-commands-rebirth-name-aliases)
  birth-metrics   every metric of a birth has a name and a datatype; aliases
                  unique over the edge node (NBIRTH and its DBIRTHs)
  data-metrics    NDATA/DDATA metrics: an alias or name from the current
                  birth, nothing else
  seq             every message of the node but NDEATH: seq = the previous
                  one + 1 (mod 256), NBIRTH 0
  order           DBIRTH, DDATA, DDEATH only while the node is born (after
                  NBIRTH, before NDEATH); DDATA only after that device's
                  DBIRTH and before its DDEATH
  bdseq           an NDEATH carries the bdSeq of the NBIRTH it ends (or of
                  one not born yet: the Will of a connection that never
                  published its NBIRTH); an NBIRTH on a new connection (after
                  an NDEATH) has a bdSeq one more than the last (mod 256,
                  `bdseq_step` more with refused CONNECTs between); a rebirth
                  on the same connection keeps it
  time-order      a device's DBIRTH and DDATA timestamps never step back
                  between its DBIRTH and its DDEATH

check(msgs) takes host.js's records (dicts with topic, qos, retain, payload)
in arrival order and returns the violations as strings (empty: conformant).
"""

DATA_KINDS = ("NBIRTH", "DBIRTH", "NDATA", "DDATA", "DDEATH")


def _topic(t):
    parts = t.split("/")
    if len(parts) < 4 or parts[0] != "spBv1.0" or parts[1] == "STATE":
        return None
    return parts[1], parts[2], parts[3], (parts[4] if len(parts) > 4 else None)


class _Node:
    def __init__(self):
        self.born = False
        self.bd = None          # the bdSeq of the current (or last) NBIRTH
        self.dead_since = True  # an NDEATH (or nothing) since the last NBIRTH
        self.seq = None
        self.aliases = {}       # alias -> (device or None, name)
        self.names = {}         # (device or None) -> set of names
        self.devices = set()    # born devices
        self.dev_ts = {}        # device -> last timestamp


def check(msgs, bdseq_step=1):
    out = []
    nodes = {}

    def bad(i, m, rule, why):
        out.append("#%d %s: %s: %s" % (i, m["topic"], rule, why))

    for i, m in enumerate(msgs):
        t = _topic(m.get("topic", ""))
        if t is None:
            continue
        group, kind, edge, dev = t
        node = nodes.setdefault((group, edge), _Node())
        p = m.get("payload")
        if p is None:
            if kind not in ("NCMD", "DCMD"):
                bad(i, m, "payload", "not decodable by Tahu: %s" % m.get("error"))
            continue
        metrics = p.get("metrics") or []
        if kind in ("NCMD", "DCMD"):
            continue
        # qos-retain
        want = 1 if kind == "NDEATH" else 0
        if m.get("qos") != want or m.get("retain"):
            bad(i, m, "qos-retain", "QoS %s retain %s (want QoS %d, not retained)"
                % (m.get("qos"), m.get("retain"), want))
        # timestamp
        if kind in DATA_KINDS and p.get("timestamp") is None:
            bad(i, m, "timestamp", "no payload timestamp")
        if kind in ("NBIRTH", "DBIRTH", "NDATA", "DDATA"):
            missing = [x.get("name") or x.get("alias") for x in metrics
                       if x.get("timestamp") is None]
            if missing:
                bad(i, m, "timestamp", "%d metrics without a timestamp (%s ...)"
                    % (len(missing), missing[0]))
        seq = p.get("seq")
        if kind == "NDEATH":
            bd = [x.get("value") for x in metrics if x.get("name") == "bdSeq"]
            if not bd:
                bad(i, m, "bdseq", "NDEATH without bdSeq")
                continue
            if node.born and bd[0] != node.bd:
                continue  # an old connection's: a host ignores it
            if not node.born and node.bd is not None and node.dead_since and \
                    (bd[0] - node.bd) % 256 > bdseq_step:
                bad(i, m, "bdseq", "NDEATH bdSeq %s after %s" % (bd[0], node.bd))
            node.bd = bd[0]
            node.born, node.dead_since, node.devices = False, True, set()
            continue
        if kind == "NBIRTH":
            bd = [x for x in metrics if x.get("name") == "bdSeq"]
            rb = [x for x in metrics if x.get("name") == "Node Control/Rebirth"]
            if seq != 0:
                bad(i, m, "nbirth", "seq %s (want 0)" % seq)
            if not bd or bd[0].get("type") != "Int64":
                bad(i, m, "nbirth", "no bdSeq Int64 metric")
            if not rb or rb[0].get("type") != "Boolean":
                bad(i, m, "nbirth", "no Node Control/Rebirth Boolean metric")
            elif rb[0].get("alias") is not None:
                bad(i, m, "nbirth", "Node Control/Rebirth has alias %s" % rb[0]["alias"])
            if bd:
                v = bd[0].get("value")
                if node.bd is not None and node.dead_since:
                    step = (v - node.bd) % 256
                    ok = step == 1 if bdseq_step == 1 else 1 <= step <= bdseq_step
                    if not ok:
                        bad(i, m, "bdseq", "new connection with bdSeq %s after %s" % (v, node.bd))
                elif node.bd is not None and v != node.bd:
                    bad(i, m, "bdseq", "rebirth with bdSeq %s, the connection has %s"
                        % (v, node.bd))
                node.bd = v
            node.born, node.dead_since, node.seq = True, False, 0
            node.aliases, node.names, node.devices, node.dev_ts = {}, {}, set(), {}
            _birth(node, None, metrics, lambda why: bad(i, m, "birth-metrics", why))
            continue
        # seq, order
        if not node.born:
            bad(i, m, "order", "%s while the node is not born" % kind)
        elif seq is None or node.seq is None or seq != (node.seq + 1) % 256:
            bad(i, m, "seq", "seq %s after %s" % (seq, node.seq))
        if seq is not None:
            node.seq = seq
        ts = p.get("timestamp")
        if kind == "DBIRTH":
            node.devices.add(dev)
            for a in [a for a, v in node.aliases.items() if v[0] == dev]:
                del node.aliases[a]
            _birth(node, dev, metrics, lambda why: bad(i, m, "birth-metrics", why))
            node.dev_ts[dev] = ts
        elif kind == "DDEATH":
            node.devices.discard(dev)
            node.dev_ts.pop(dev, None)
        elif kind in ("DDATA", "NDATA"):
            if kind == "DDATA" and dev not in node.devices:
                bad(i, m, "order", "DDATA before the device's DBIRTH")
            for x in metrics:
                a, name = x.get("alias"), x.get("name")
                if a is not None and node.aliases.get(a, (None, None))[0] != dev:
                    bad(i, m, "data-metrics", "alias %s not in the birth" % a)
                elif a is None and name not in node.names.get(dev, ()):
                    bad(i, m, "data-metrics", "metric %r not in the birth" % name)
            if kind == "DDATA" and dev in node.dev_ts and ts is not None:
                if node.dev_ts[dev] is not None and ts < node.dev_ts[dev]:
                    bad(i, m, "time-order", "timestamp %d ms before the previous one"
                        % (node.dev_ts[dev] - ts))
                node.dev_ts[dev] = ts
    return out


def _birth(node, dev, metrics, bad):
    names = node.names.setdefault(dev, set())
    for x in metrics:
        if not x.get("name") or x.get("type") is None:
            bad("a metric without name or datatype: %r" % (x,))
        names.add(x.get("name"))
        a = x.get("alias")
        if a is not None:
            if a in node.aliases:
                bad("alias %s twice (%s, %s)" % (a, node.aliases[a][1], x.get("name")))
            node.aliases[a] = (dev, x.get("name"))
