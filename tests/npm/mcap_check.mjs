// The MCAP files saulctl writes, read by Foxglove's own library (@mcap/core, with @mcap/support's zstd/lz4) and
// checked with a JSON Schema validator (ajv): the independent side of tests/cli/mcap.sh.
//
//   node mcap_check.mjs verify FILE.mcap DECODE.jsonl STATS.json
//       Reads FILE with the indexed reader (summary, chunk indexes) and with the streaming reader (CRCs checked);
//       both must give the same messages. Every message must validate against its channel's JSON Schema; per
//       channel, the counts must equal what `saulctl stats --json` (STATS.json) says; the frames and decoded
//       messages must equal `saulctl decode --json` (DECODE.jsonl), line by line: a decoded message holds decode's
//       values but for its type and a VESC's controller_id, which its topic must say (/saul/TYPE,
//       /vesc/CONTROLLER/TYPE without "vesc_"). Prints the counts per topic.
//   node mcap_check.mjs stream FILE.mcap
//       Streams FILE as far as it goes (a file cut short): prints {"frames":N,"error":"..."}.
//   node mcap_check.mjs stream_cuts FILE.mcap STEP
//       stream for FILE cut at every STEP bytes (STEP, 2 STEP, ... below its size), one process for all the cuts:
//       prints "CUT FRAMES" per line.
//   node mcap_check.mjs chunks FILE.mcap
//       From the summary: each chunk's end offset and how many /can/frames messages it holds, one per line.
//   node mcap_check.mjs write OUT.mcap DECODE.jsonl
//       Writes the frames of DECODE.jsonl with @mcap/core's McapWriter on "/can/frames" in saulctl's schema (and
//       a channel of another topic that saulctl must pass over), in chunks of 4 KiB, uncompressed.
//   node mcap_check.mjs trace FILE.mcap DECODE.jsonl
//       A loop trace's MCAP (indexed reader): "/saul/loop_trace" holds one message per line of `saulctl decode
//       --json` of the trace (DECODE.jsonl), each valid against the channel's schema; the first and last equal
//       decode's, log time = time_s in ns; a Metadata record "saulctl" names the source. Prints the count.
//   node mcap_check.mjs serial_stream FILE.mcap
//       A serial recording streamed as far as it goes (a recorder killed): prints {"log":[...],"topics":{...},
//       "error":...}: its /serial/bytes messages as serial-log lines ("(s.us) LINK PROTOCOL HEX", docs/captures.md),
//       the messages per topic, and what the reader stopped at (null: nothing but a file that ends).
//   node mcap_check.mjs serial FILE.mcap DECODE.jsonl [TOLERANCE_NS]
//       A serial capture's MCAP: both readers, every message valid against its schema (as verify); the messages
//       off /serial/bytes, in file order, equal the lines of `saulctl decode --json` of the capture (DECODE.jsonl)
//       one for one (value, link and protocol of the channel, log time = the line's time, exactly or within
//       TOLERANCE_NS); a Metadata record per link. Prints the counts per topic.
import { McapIndexedReader, McapStreamReader, McapWriter } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import Ajv from "ajv";
import { promises as fs } from "node:fs";
import { readFileSync, writeFileSync } from "node:fs";

const [, , mode, file, arg2, arg3] = process.argv;
const text = new TextDecoder();
const fail = (msg) => {
  console.error(`mcap_check: ${file}: ${msg}`);
  process.exit(1);
};
const lines = (path) =>
  readFileSync(path, "utf8")
    .split("\n")
    .filter((l) => l.length > 0)
    .map((l) => {
      // timestamp_ns exceeds 2^53: taken from the text, not from JSON.parse's double
      const v = JSON.parse(l);
      const t = /"timestamp_ns":(\d+)/.exec(l);
      if (t) v.frame.timestamp_ns = t[1];
      return v;
    });

// A JSON value with its object keys sorted, to compare without caring about member order.
const canon = (v) =>
  Array.isArray(v)
    ? v.map(canon)
    : v && typeof v === "object"
      ? Object.fromEntries(Object.keys(v).sort().map((k) => [k, canon(v[k])]))
      : v;
const same = (a, b) => JSON.stringify(canon(a)) === JSON.stringify(canon(b));

async function streamAll(bytes, handlers) {
  const reader = new McapStreamReader({ decompressHandlers: handlers, validateCrcs: true });
  reader.append(bytes);
  const channels = new Map();
  const schemas = new Map();
  const messages = [];
  let error;
  try {
    for (let r; (r = reader.nextRecord()); ) {
      if (r.type === "Schema") schemas.set(r.id, r);
      if (r.type === "Channel") channels.set(r.id, r);
      if (r.type === "Message") messages.push(r);
    }
  } catch (e) {
    error = String(e.message ?? e);
  }
  return { channels, schemas, messages, error, done: reader.done() };
}

// The indexed reader over a file in memory.
async function indexedOf(bytes) {
  const readable = {
    size: async () => BigInt(bytes.length),
    read: async (offset, length) => bytes.subarray(Number(offset), Number(offset + length)),
  };
  return McapIndexedReader.Initialize({ readable, decompressHandlers: await loadDecompressHandlers() });
}

// FILE through both readers: the indexed one (summary, chunk indexes; log-time order) and the streaming one (CRCs
// checked; file order), which must hold the same messages; the Statistics record must count them.
async function readBoth() {
  const handlers = await loadDecompressHandlers();
  const bytes = readFileSync(file);
  const handle = await fs.open(file, "r");
  const readable = {
    size: async () => BigInt((await handle.stat()).size),
    read: async (offset, length) => {
      const buf = Buffer.alloc(Number(length));
      await handle.read(buf, 0, Number(length), Number(offset));
      return buf;
    },
  };
  const indexed = await McapIndexedReader.Initialize({ readable, decompressHandlers: handlers });
  if (indexed.chunkIndexes.length === 0) fail("no chunk indexes in the summary");
  const fromIndex = [];
  for await (const m of indexed.readMessages()) fromIndex.push(m);
  // the handle stays open: serial() reads Metadata through the indexed reader later (closed at exit)
  const streamed = await streamAll(bytes, handlers);
  if (streamed.error || !streamed.done) fail(`streaming reader: ${streamed.error ?? "did not reach the end"}`);
  if (streamed.messages.length !== fromIndex.length)
    fail(`streaming reader read ${streamed.messages.length} messages, the indexed one ${fromIndex.length}`);

  // The indexed reader gives log-time order, the stream file order: compare as multisets per channel.
  const key = (m) => `${m.channelId}|${m.logTime}|${text.decode(m.data)}`;
  const a = fromIndex.map(key).sort();
  const b = streamed.messages.map(key).sort();
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) fail(`indexed and streamed messages differ: ${a[i]} / ${b[i]}`);
  if (indexed.statistics === undefined) fail("no Statistics record");
  if (Number(indexed.statistics.messageCount) !== fromIndex.length)
    fail(`Statistics says ${indexed.statistics.messageCount} messages, the file holds ${fromIndex.length}`);
  return { indexed, streamed };
}

// Every message against its channel's JSON Schema (jsonschema, json messages); the counts per topic.
function validateAll(indexed, streamed) {
  const ajv = new Ajv({ strict: false, allErrors: false });
  const validators = new Map();
  const counts = {};
  for (const m of streamed.messages) {
    const channel = indexed.channelsById.get(m.channelId);
    if (!channel) fail(`message on channel ${m.channelId}, not in the summary`);
    if (channel.messageEncoding !== "json") fail(`${channel.topic}: message encoding ${channel.messageEncoding}`);
    const schema = indexed.schemasById.get(channel.schemaId);
    if (!schema || schema.encoding !== "jsonschema") fail(`${channel.topic}: no jsonschema schema`);
    if (!validators.has(schema.id)) validators.set(schema.id, ajv.compile(JSON.parse(text.decode(schema.data))));
    const value = JSON.parse(text.decode(m.data));
    const validate = validators.get(schema.id);
    if (!validate(value))
      fail(`${channel.topic} at ${m.logTime}: ${JSON.stringify(value)} fails its schema: ${ajv.errorsText(validate.errors)}`);
    counts[channel.topic] = (counts[channel.topic] ?? 0) + 1;
  }
  return counts;
}

async function verify() {
  const { indexed, streamed } = await readBoth();
  const counts = validateAll(indexed, streamed);

  // Counts per channel = saulctl stats: all frames on /can/frames, each id's decoded frames on its topic.
  const stats = JSON.parse(readFileSync(arg3, "utf8"));
  const expected = { "/can/frames": stats.frames };
  for (const id of stats.ids) {
    if (!id.type) continue;
    const decoded = id.count - id.decode_errors - (id.remote ?? 0);
    if (decoded <= 0) continue;
    const topic = id.extended ? `/vesc/${id.id & 0xff}/${id.type.replace(/^vesc_/, "")}` : `/saul/${id.type}`;
    expected[topic] = (expected[topic] ?? 0) + decoded;
  }
  if (!same(counts, expected)) fail(`counts per topic ${JSON.stringify(canon(counts))}, saulctl stats says ${JSON.stringify(canon(expected))}`);

  // The values = decode --json: in file order, each frame, then its decoded message when it has one.
  const decoded = lines(arg2);
  let i = 0;
  for (const line of decoded) {
    const m = streamed.messages[i++];
    const channel = indexed.channelsById.get(m?.channelId);
    if (!m || channel.topic !== "/can/frames") fail(`frame ${JSON.stringify(line.frame)}: not next on /can/frames`);
    const { timestamp_ns, ...frame } = line.frame;
    frame.interface = line.interface;
    if (!same(JSON.parse(text.decode(m.data)), frame)) fail(`frame ${text.decode(m.data)} != decode's ${JSON.stringify(frame)}`);
    if (BigInt(timestamp_ns) !== m.logTime) fail(`frame log time ${m.logTime} != decode's ${timestamp_ns}`);
    if (line.message) {
      // decode's message without what the topic says: its type, and a VESC's controller_id
      const { type, controller_id, ...physical } = line.message;
      const want = controller_id === undefined ? `/saul/${type}` : `/vesc/${controller_id}/${type.replace(/^vesc_/, "")}`;
      const d = streamed.messages[i++];
      const value = d && JSON.parse(text.decode(d.data));
      if (!d || !same(value, physical)) fail(`decoded ${JSON.stringify(value)} != decode's ${JSON.stringify(line.message)} (type, controller_id left out)`);
      const topic = indexed.channelsById.get(d.channelId).topic;
      if (topic !== want) fail(`decoded ${JSON.stringify(line.message)} on ${topic}, not on ${want}`);
      if (d.logTime !== m.logTime) fail(`decoded message at ${d.logTime}, its frame at ${m.logTime}`);
    }
  }
  if (i !== streamed.messages.length) fail(`${streamed.messages.length - i} messages more than decode --json's lines`);
  console.log(JSON.stringify(canon(counts)));
}

async function framesStreamed(bytes, handlers) {
  const s = await streamAll(bytes, handlers);
  return { frames: s.messages.filter((m) => s.channels.get(m.channelId)?.topic === "/can/frames").length, error: s.error };
}

async function stream() {
  const { frames, error } = await framesStreamed(readFileSync(file), await loadDecompressHandlers());
  console.log(JSON.stringify({ frames, error: error ?? null }));
}

async function streamCuts() {
  const handlers = await loadDecompressHandlers();
  const bytes = readFileSync(file);
  const step = Number(arg2);
  if (!(step > 0)) fail(`stream_cuts needs a step in bytes, not ${arg2}`);
  for (let at = step; at < bytes.length; at += step)
    console.log(`${at} ${(await framesStreamed(bytes.subarray(0, at), handlers)).frames}`);
}

async function chunks() {
  const bytes = readFileSync(file);
  const indexed = await indexedOf(bytes);
  const frames = [...indexed.channelsById.values()].find((c) => c.topic === "/can/frames").id;
  for (const c of indexed.chunkIndexes) {
    // The chunk's Message Index record of the frames channel (opcode, length u64, channel u16, then the array's
    // byte length u32) says how many frames it holds: 16 bytes (time, offset) each.
    const at = Number(c.messageIndexOffsets.get(frames) ?? -1);
    let count = 0;
    if (at >= 0) count = Number(Buffer.from(bytes.subarray(at + 11, at + 15)).readUInt32LE(0)) / 16;
    console.log(`${c.chunkStartOffset + c.chunkLength} ${count}`);
  }
}

async function write() {
  const chunks = [];
  let position = 0n;
  const writable = {
    position: () => position,
    write: async (buf) => {
      chunks.push(Buffer.from(buf));
      position += BigInt(buf.byteLength);
    },
  };
  const writer = new McapWriter({ writable, chunkSize: 4096 });
  await writer.start({ profile: "", library: "@mcap/core (saul-tee test)" });
  const schemaText = Buffer.from('{"type":"object"}'); // saulctl goes by the topic and the schema's name
  const schemaId = await writer.registerSchema({ name: "saul.can_frame", encoding: "jsonschema", data: schemaText });
  const other = await writer.registerChannel({ topic: "/other", messageEncoding: "json", schemaId: 0, metadata: new Map() });
  const frames = await writer.registerChannel({ topic: "/can/frames", messageEncoding: "json", schemaId, metadata: new Map() });
  let seq = 0;
  for (const line of lines(arg2)) {
    const { timestamp_ns, ...frame } = line.frame;
    frame.interface = line.interface;
    const t = BigInt(timestamp_ns);
    await writer.addMessage({ channelId: frames, sequence: seq++, logTime: t, publishTime: t, data: Buffer.from(JSON.stringify(frame)) });
    await writer.addMessage({ channelId: other, sequence: seq, logTime: t, publishTime: t, data: Buffer.from('{"not":"a frame"}') });
  }
  await writer.end();
  writeFileSync(file, Buffer.concat(chunks));
}

async function trace() {
  const bytes = readFileSync(file);
  const indexed = await indexedOf(bytes);
  const channel = [...indexed.channelsById.values()].find((c) => c.topic === "/saul/loop_trace");
  if (!channel || channel.messageEncoding !== "json") fail("no json channel /saul/loop_trace");
  const schema = indexed.schemasById.get(channel.schemaId);
  if (!schema || schema.encoding !== "jsonschema") fail("/saul/loop_trace: no jsonschema schema");
  const validate = new Ajv({ strict: false }).compile(JSON.parse(text.decode(schema.data)));
  const messages = [];
  for await (const m of indexed.readMessages({ topics: ["/saul/loop_trace"] })) {
    const value = JSON.parse(text.decode(m.data));
    if (!validate(value)) fail(`${JSON.stringify(value)} fails its schema`);
    messages.push({ value, logTime: m.logTime });
  }
  const decoded = lines(arg2);
  if (messages.length !== decoded.length) fail(`${messages.length} messages, decode --json has ${decoded.length} lines`);
  for (const i of [0, decoded.length - 1]) {
    const { value, logTime } = messages[i];
    if (!same(value, decoded[i])) fail(`message ${i}: ${JSON.stringify(value)} != decode's ${JSON.stringify(decoded[i])}`);
    if (logTime !== BigInt(Math.round(decoded[i].time_s * 1e6)) * 1000n) fail(`message ${i}: log time ${logTime}`);
  }
  const metadata = [];
  for await (const m of indexed.readMetadata({ name: "saulctl" })) metadata.push(m);
  if (metadata.length !== 1 || metadata[0].metadata.get("source_format") !== "loop trace")
    fail("no Metadata record saulctl with source_format 'loop trace'");
  console.log(messages.length);
}

// decode --json's time text ("1763800000.000100") in ns, exactly.
const nsOf = (time) => {
  const [sec, frac = ""] = time.split(".");
  return BigInt(sec) * 1000000000n + BigInt((frac + "000000000").slice(0, 9));
};

async function serial() {
  const { indexed, streamed } = await readBoth();
  const counts = validateAll(indexed, streamed);
  const tolerance = BigInt(arg3 ?? 0);
  // The decoded channels in file order = decode --json's lines in order: the same value (its "message", or its
  // "error" on .../undecoded), on a channel of the line's link and protocol, at the line's time.
  const decoded = readFileSync(arg2, "utf8").split("\n").filter((l) => l.length > 0).map((l) => JSON.parse(l));
  const messages = streamed.messages.filter((m) => indexed.channelsById.get(m.channelId).topic !== "/serial/bytes");
  if (messages.length !== decoded.length) fail(`${messages.length} decoded messages, decode --json has ${decoded.length} lines`);
  decoded.forEach((line, i) => {
    const m = messages[i];
    const channel = indexed.channelsById.get(m.channelId);
    const value = JSON.parse(text.decode(m.data));
    const want = line.message ?? line.error;
    if (!same(value, want)) fail(`message ${i} on ${channel.topic}: ${JSON.stringify(value)} != decode's ${JSON.stringify(want)}`);
    const kind = line.message ? want.type : "undecoded";
    if (!new RegExp(`^/serial/${line.protocol}(_[0-9]+)?/${kind}$`).test(channel.topic))
      fail(`message ${i} (${line.protocol} ${kind}) on ${channel.topic}`);
    if (channel.metadata.get("link") !== line.link || channel.metadata.get("protocol") !== line.protocol)
      fail(`${channel.topic}: link ${channel.metadata.get("link")}, decode says ${line.link}`);
    const d = m.logTime - nsOf(line.time);
    if (d > tolerance || -d > tolerance) fail(`message ${i} on ${channel.topic}: log time ${m.logTime}, decode's time ${line.time}`);
  });
  // A Metadata record per link, and saulctl's.
  const links = new Set();
  for await (const r of indexed.readMetadata({ name: "serial_link" })) links.add(r.metadata.get("link"));
  for (const line of decoded) if (!links.has(line.link)) fail(`no serial_link Metadata record for ${line.link}`);
  let ours = 0;
  for await (const _ of indexed.readMetadata({ name: "saulctl" })) ours++;
  if (ours !== 1) fail(`${ours} Metadata records "saulctl"`);
  console.log(JSON.stringify(canon(counts)));
}

async function serialStream() {
  const s = await streamAll(readFileSync(file), await loadDecompressHandlers());
  const topics = {};
  const log = [];
  for (const m of s.messages) {
    const topic = s.channels.get(m.channelId)?.topic;
    topics[topic] = (topics[topic] ?? 0) + 1;
    if (topic !== "/serial/bytes") continue;
    const v = JSON.parse(text.decode(m.data));
    const sec = String(m.logTime / 1000000000n).padStart(10, "0");
    const us = String((m.logTime % 1000000000n) / 1000n).padStart(6, "0");
    log.push(`(${sec}.${us}) ${v.link} ${v.protocol} ${v.data || "-"}${v.uart_errors.map((e) => ` !${e}`).join("")}`);
  }
  console.log(JSON.stringify({ log, topics: canon(topics), error: s.error ?? null }));
}

if (mode === "verify") await verify();
else if (mode === "serial_stream") await serialStream();
else if (mode === "trace") await trace();
else if (mode === "serial") await serial();
else if (mode === "stream") await stream();
else if (mode === "stream_cuts") await streamCuts();
else if (mode === "write") await write();
else if (mode === "chunks") await chunks();
else fail(`unknown mode ${mode}`);
process.exit(0); // a decompression handler may keep the event loop alive
