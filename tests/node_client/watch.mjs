// Connect @foxglove/ws-protocol's FoxgloveClient to an msd-bench live view and print what it gets.
// Usage: node watch.mjs URL SUBPROTOCOLS(comma-separated) [TOPIC]
// Prints JSON lines: {"subprotocol": ...}, {"channels": [...]}, then one {"row": [stamp_ns, x, v, u]}
// per message on TOPIC, decoded with the protobuf schema the server advertised; ends when the
// server closes. A refused handshake prints {"error": ...} and exits 3.
import wsProtocol from "@foxglove/ws-protocol";
import protobuf from "protobufjs";
import descriptor from "protobufjs/ext/descriptor/index.js";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;

const [url, protocols, topic = "/plant/joint_states"] = process.argv.slice(2);
const say = (doc) => process.stdout.write(JSON.stringify(doc) + "\n");
const ws = new WebSocket(url, protocols.split(","));
ws.on("unexpected-response", (_req, res) => { say({ error: `HTTP ${res.statusCode}` }); process.exit(3); });
ws.on("error", (err) => { say({ error: String(err.message) }); process.exit(3); });
ws.on("open", () => say({ subprotocol: ws.protocol }));
const client = new FoxgloveClient({ ws });
const decoders = new Map();
client.on("advertise", (channels) => {
  say({ channels: channels.map((c) => ({ topic: c.topic, schemaName: c.schemaName, encoding: c.encoding })) });
  for (const c of channels) {
    if (c.topic !== topic) continue;
    const set = descriptor.FileDescriptorSet.decode(Buffer.from(c.schema, "base64"));
    const type = protobuf.Root.fromDescriptor(set).lookupType(c.schemaName);
    decoders.set(client.subscribe(c.id), type);
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const type = decoders.get(subscriptionId);
  if (!type) return;
  const m = type.toObject(type.decode(new Uint8Array(data.buffer, data.byteOffset, data.byteLength)),
                          { longs: String, defaults: true });
  const j = m.joints[0];
  const stamp = BigInt(m.timestamp.seconds) * 1000000000n + BigInt(m.timestamp.nanos);
  say({ row: [stamp.toString(), j.position, j.velocity, j.effort] });
});
client.on("close", () => process.exit(0));
