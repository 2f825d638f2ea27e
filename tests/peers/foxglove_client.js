// The official Foxglove WebSocket client (npm @foxglove/ws-protocol, messages decoded and
// encoded with @foxglove/rosmsg and @foxglove/rosmsg2-serialization) against a physskin node's
// live view: lists the advertised channels, reads the parameters, subscribes to the deformed
// cloud and the markers and decodes them, then publishes a physskin/msg/Interaction that
// pushes the objects, and keeps decoding. Writes what it saw to a JSON file.
//
// node foxglove_client.js URL OUT.json INTERACTION_SCHEMA.txt NODE_NAME
const fs = require("fs");
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader, MessageWriter } = require("@foxglove/rosmsg2-serialization");
const WebSocket = require("ws");

const [url, outPath, schemaPath, nodeName] = process.argv.slice(2);
const deformedTopic = `${nodeName}/deformed_points`;
const markersTopic = `${nodeName}/markers`;
const interactionTopic = `${nodeName}/interaction`;

// The wall clock (which the node stamps with) to the microsecond.
const { performance } = require("perf_hooks");
const nowNs = () => BigInt(Math.round((performance.timeOrigin + performance.now()) * 1000)) * 1000n;
const stampNs = (h) => BigInt(h.stamp.sec) * 1000000000n + BigInt(h.stamp.nanosec);

function cloudSummary(msg) {
  const view = new DataView(msg.data.buffer, msg.data.byteOffset, msg.data.byteLength);
  const offsets = Object.fromEntries(msg.fields.map((f) => [f.name, f.offset]));
  const count = msg.width * msg.height;
  const c = [0, 0, 0];
  const first = [];
  for (let i = 0; i < count; i++) {
    const p = ["x", "y", "z"].map((a) => view.getFloat32(i * msg.point_step + offsets[a], true));
    if (i < 3) first.push(p);
    for (let d = 0; d < 3; d++) c[d] += p[d] / count;
  }
  return { count, first, centroid: c };
}

const seen = {
  server: null,
  channels: [],
  parameters: [],
  setApplied: null,
  clouds: [],
  markers: [],
  pushedAtNs: null,
  latencyMs: [],
  // The subprotocol the server answered with, per connection.
  protocols: [],
};
// The library as it ships offers only its own name for the protocol, foxglove.websocket.v1
// (as Lichtblick and Foxglove Studio up to 1.87 do); the node's server must take it.
const socket = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
socket.on("open", () => {
  seen.protocols.push(socket.protocol);
});
const client = new FoxgloveClient({ ws: socket });
// Today's Foxglove app offers the SDK's name, foxglove.sdk.v1: a second connection with it
// alone, closed once the server has answered.
const probe = new WebSocket(url, ["foxglove.sdk.v1"]);
probe.on("open", () => {
  seen.protocols.push(probe.protocol);
  probe.close();
});
probe.on("error", (e) => {
  console.error("probe error", e);
  process.exit(2);
});
const readers = new Map();

client.on("serverInfo", (info) => {
  seen.server = { name: info.name, capabilities: info.capabilities };
  client.getParameters([], "all");
});
client.on("parameterValues", (event) => {
  if (event.id === "all") {
    seen.parameters = event.parameters.map((p) => p.name);
    // One that may change while the node runs, and one that may not (rate_hz).
    client.setParameters(
      [
        { name: "material.young", value: 300000.0 },
        { name: "rate_hz", value: 30.0 },
      ],
      "set",
    );
  } else if (event.id === "set") {
    seen.setApplied = event.parameters.map((p) => [p.name, p.value]);
  }
});
client.on("advertise", (channels) => {
  for (const ch of channels) {
    seen.channels.push({ topic: ch.topic, encoding: ch.encoding, schemaName: ch.schemaName });
    if (ch.topic !== deformedTopic && ch.topic !== markersTopic) continue;
    const reader = new MessageReader(parse(ch.schema, { ros2: true }));
    readers.set(client.subscribe(ch.id), { topic: ch.topic, reader });
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const arrived = nowNs();
  const sub = readers.get(subscriptionId);
  if (!sub) return;
  const msg = sub.reader.readMessage(data);
  if (sub.topic === deformedTopic) {
    const stamp = stampNs(msg.header);
    seen.latencyMs.push(Number(arrived - stamp) / 1e6);
    seen.clouds.push({ stampNs: stamp.toString(), arrivedNs: arrived.toString(), ...cloudSummary(msg) });
  } else {
    const m = msg.markers[0];
    seen.markers.push({
      count: msg.markers.length,
      stampNs: m ? stampNs(m.header).toString() : null,
      points: m ? m.points.length : 0,
    });
  }
});
client.on("error", (e) => {
  console.error("client error", e);
  process.exit(2);
});

function push() {
  const schema = fs.readFileSync(schemaPath, "utf8");
  const writer = new MessageWriter(parse(schema, { ros2: true }));
  const channel = client.advertise({
    topic: interactionTopic,
    encoding: "cdr",
    schemaName: "physskin/msg/Interaction",
    schema,
    schemaEncoding: "ros2msg",
  });
  const poke = {
    header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "" },
    shape_id: 0,
    kind: 0, // FORCE
    point: { x: 0.0, y: 0.0, z: 0.1 },
    force: { x: 0.0, y: 40.0, z: 0.0 },
    duration: 0.5,
    radius: 0.0,
  };
  seen.pushedAtNs = nowNs().toString();
  client.sendMessage(channel, writer.writeMessage(poke));
}

const deadline = Date.now() + 60000;
const timer = setInterval(() => {
  const enough = seen.clouds.length >= 60 && seen.markers.length >= 5;
  if (seen.pushedAtNs === null && enough) push();
  const afterPush = seen.pushedAtNs && seen.clouds.filter((c) => BigInt(c.stampNs) > BigInt(seen.pushedAtNs)).length;
  if ((afterPush && afterPush >= 90) || Date.now() > deadline) {
    clearInterval(timer);
    fs.writeFileSync(outPath, JSON.stringify(seen, null, 1));
    const sorted = [...seen.latencyMs].sort((a, b) => a - b);
    const q = (f) => sorted[Math.min(sorted.length - 1, Math.floor(f * sorted.length))];
    console.log(`clouds ${seen.clouds.length}, markers ${seen.markers.length}, stamp to arrival ms: median ${q(0.5)}, p99 ${q(0.99)}`);
    client.close();
    process.exit(0);
  }
}, 50);
