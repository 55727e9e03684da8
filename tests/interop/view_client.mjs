// A live-view client built on the independent @foxglove/ws-protocol package
// (tests/interop/test_view_interop.cpp): connects to ws://127.0.0.1:PORT, subscribes to every
// advertised channel, decodes every message (JSON), and after SECONDS prints per channel the
// schema, the count, the rate (Hz over the time it was subscribed), the first message's keys and,
// for foxglove.ImageAnnotations, the most feature points (POINTS annotations) in one message.
// Before that it connects and disconnects RECONNECTS times (the server must keep serving).
//   node view_client.mjs PORT SECONDS RECONNECTS
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;

const [port, seconds, reconnects] = process.argv.slice(2).map(Number);
const url = `ws://127.0.0.1:${port}`;

function connect() {
  return new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
}

async function churn(n) {
  for (let i = 0; i < n; i++) {
    await new Promise((resolve, reject) => {
      const c = connect();
      c.on("error", reject);
      c.on("advertise", (channels) => {
        for (const ch of channels) c.subscribe(ch.id);
        setTimeout(() => { c.close(); resolve(); }, 50);
      });
    });
  }
}

async function watch() {
  const client = connect();
  const channels = new Map();
  const bySub = new Map();
  let start = 0;
  let errors = [];
  client.on("error", (e) => errors.push(String(e)));
  client.on("advertise", (list) => {
    start = performance.now();
    for (const ch of list) {
      const sub = client.subscribe(ch.id);
      const entry = { topic: ch.topic, schema: ch.schemaName, encoding: ch.encoding, count: 0, bad: 0, keys: null, features_max: 0 };
      channels.set(ch.topic, entry);
      bySub.set(sub, entry);
    }
  });
  client.on("message", ({ subscriptionId, data }) => {
    const entry = bySub.get(subscriptionId);
    if (!entry) return;
    try {
      const msg = JSON.parse(new TextDecoder().decode(data));
      if (entry.keys === null) entry.keys = Object.keys(msg).sort();
      if (Array.isArray(msg.points)) {
        const features = msg.points.filter((p) => p.type === 1).reduce((n, p) => n + p.points.length, 0);
        entry.features_max = Math.max(entry.features_max, features);
      }
      entry.count++;
    } catch {
      entry.bad++;
    }
  });
  await new Promise((resolve) => setTimeout(resolve, seconds * 1000));
  const elapsed = (performance.now() - start) / 1000;
  client.close();
  const out = {};
  for (const [topic, e] of channels) out[topic] = { ...e, rate_hz: e.count / elapsed };
  console.log(JSON.stringify({ elapsed_s: elapsed, errors, channels: out }));
}

try {
  await churn(reconnects);
  await watch();
  process.exit(0);
} catch (e) {
  console.error(`view_client: ${e.stack ?? e}`);
  process.exit(1);
}
