// Reads an MCAP file with Foxglove's libraries and prints JSON: the summary, and every message
// decoded from its channel's ros2msg schema. Read twice, through the summary's chunk and message
// indexes (McapIndexedReader, as Foxglove seeks) and linearly (McapStreamReader), CRCs checked.
// Usage: node read.mjs FILE.mcap
import { open } from "node:fs/promises";
import { readFileSync } from "node:fs";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";

const path = process.argv[2];
const handle = await open(path, "r");
const readable = {
  size: async () => BigInt((await handle.stat()).size),
  read: async (offset, length) => {
    const buffer = new Uint8Array(Number(length));
    await handle.read(buffer, 0, buffer.length, Number(offset));
    return buffer;
  },
};
const reader = await McapIndexedReader.Initialize({ readable });

const readers = new Map();
for (const [id, channel] of reader.channelsById) {
  const schema = reader.schemasById.get(channel.schemaId);
  const definitions = parse(new TextDecoder().decode(schema.data), { ros2: true });
  readers.set(id, new MessageReader(definitions));
}

// Typed arrays (uint8[]) as base64, bigints as strings, maps as objects.
const plain = (value) => {
  if (value instanceof Map) return plain(Object.fromEntries(value));
  if (value instanceof Uint8Array) return { base64: Buffer.from(value).toString("base64") };
  if (typeof value === "bigint") return value.toString();
  if (Array.isArray(value)) return value.map(plain);
  if (value && typeof value === "object") return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  return value;
};

const messages = [];
for await (const m of reader.readMessages({ validateCrcs: true })) {
  const decoder = readers.get(m.channelId);
  const message = decoder.readMessage(m.data);
  messages.push({
    topic: reader.channelsById.get(m.channelId).topic,
    log_time: m.logTime.toString(),
    publish_time: m.publishTime.toString(),
    trailing_bytes: decoder.lastReadHadTrailingBytes(),
    message: plain(message),
  });
}

const stream = new McapStreamReader({ validateCrcs: true });
stream.append(readFileSync(path));
const streamed = { records: {}, messages: 0 };
for (let record; (record = stream.nextRecord()); ) {
  streamed.records[record.type] = (streamed.records[record.type] ?? 0) + 1;
  if (record.type === "Message") streamed.messages += 1;
}

console.log(JSON.stringify({
  profile: reader.header.profile,
  library: reader.header.library,
  statistics: plain(reader.statistics),
  chunks: reader.chunkIndexes.length,
  channels: [...reader.channelsById.values()].map((c) => ({
    id: c.id,
    topic: c.topic,
    message_encoding: c.messageEncoding,
    schema_name: reader.schemasById.get(c.schemaId).name,
    schema_encoding: reader.schemasById.get(c.schemaId).encoding,
  })),
  stream_done: stream.done(),
  streamed,
  messages,
}));
await handle.close();
