// SPDX-License-Identifier: MIT
// A Sparkplug host application on Eclipse Tahu's JavaScript packages
// (sparkplug-payload for the protobuf, and the MQTT.js that Tahu's
// sparkplug-client uses), pinned in package-lock.json: the recorder of
// tests/gateway/test_sparkplug_tck.py. It subscribes with MQTT 5 at QoS 2
// with retain-as-published, so that each message shows the QoS and the
// retain flag the gateway (or the broker's Will) published it with.
//
//   node host.js PORT GROUP [HOST]      (HOST: the broker's address, 127.0.0.1)
//   stdout: one JSON line per message: {"topic", "qos", "retain", "len",
//           "at" (ms, arrival), "payload" (Tahu's decoding) | "text" |
//           "error"}; first {"ready": true} once subscribed
//   stdin:  one JSON line per message to publish: {"topic", "payload"
//           (encoded with Tahu's encoder) | "text", "qos", "retain"}
'use strict';
const mqtt = require('mqtt');
const readline = require('readline');
const sparkplug = require('sparkplug-payload').get('spBv1.0');
// Tahu's protobuf root, for a data message's values: decodePayload reads a
// value by the metric's datatype, which a DDATA by alias does not carry;
// a host takes it from the birth (as Tahu's host applications do).
const RawPayload = require('sparkplug-payload/lib/sparkplugPayloadProto').org.eclipse.tahu.protobuf.Payload;
const birthTypes = {};  // "group/edge[/device]" -> {alias: datatype name}

const [port, group, host] = process.argv.slice(2);
const c = mqtt.connect({host: host || '127.0.0.1', port: Number(port), protocolVersion: 5,
                        clientId: 'tahu-host-' + process.pid, reconnectPeriod: 200});

function plain(v) {
    if (v !== null && typeof v === 'object') {
        if (typeof v.toNumber === 'function' && 'low' in v && 'high' in v)
            return v.toNumber();
        if (Buffer.isBuffer(v))
            return v.toString('base64');
        if (Array.isArray(v))
            return v.map(plain);
        const o = {};
        for (const k of Object.keys(v))
            o[k] = plain(v[k]);
        return o;
    }
    return v;
}

function out(o) {
    process.stdout.write(JSON.stringify(o) + '\n');
}

function byBirth(topic, buf, p) {
    const t = topic.split('/'), kind = t[2];
    const node = t[1] + '/' + t[3] + (t[4] ? '/' + t[4] : '');
    if (kind === 'NBIRTH' || kind === 'DBIRTH') {
        const types = birthTypes[node] = {};
        for (const x of p.metrics || [])
            if (x.alias !== undefined && x.alias !== null)
                types[x.alias] = x.type;
        return;
    }
    if (kind !== 'DDATA' && kind !== 'NDATA')
        return;
    const raw = RawPayload.decode(buf), types = birthTypes[node] || {};
    (p.metrics || []).forEach((x, i) => {
        if (x.type !== undefined && x.type !== null)
            return;
        const r = raw.metrics[i], member = r.value, type = types[x.alias];
        x.type = type;
        if (!member)
            return;
        let v = plain(r[member]);
        if (type === 'Int8' || type === 'Int16' || type === 'Int32')
            v = v | 0;
        else if (type === 'Boolean')
            v = !!v;
        x.value = v;
    });
}

let ready = false;
c.on('connect', () => {
    const subs = {};
    subs['spBv1.0/' + group + '/#'] = {qos: 2, rap: true};
    subs['spBv1.0/STATE/#'] = {qos: 2, rap: true};
    c.subscribe(subs, (err) => {
        if (err)
            out({error: String(err)});
        else if (!ready) {
            ready = true;
            out({ready: true});
        }
    });
});

c.on('message', (topic, buf, packet) => {
    const m = {topic, qos: packet.qos, retain: packet.retain, len: buf.length, at: Date.now()};
    if (topic.startsWith('spBv1.0/STATE/'))
        m.text = buf.toString('utf8');
    else {
        try {
            m.payload = plain(sparkplug.decodePayload(buf));
            byBirth(topic, buf, m.payload);
        } catch (e) {
            m.error = String(e);
        }
    }
    out(m);
});

readline.createInterface({input: process.stdin}).on('line', (line) => {
    if (!line.trim())
        return;
    const r = JSON.parse(line);
    const body = r.text !== undefined ? Buffer.from(r.text, 'utf8')
                                      : sparkplug.encodePayload(r.payload);
    c.publish(r.topic, body, {qos: r.qos || 0, retain: !!r.retain}, (err) => {
        out(err ? {error: String(err), published: r.topic} : {published: r.topic});
    });
});
