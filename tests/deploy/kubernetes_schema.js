// Validates Kubernetes manifests against the Kubernetes API schema, offline.
//
//   node tests/deploy/kubernetes_schema.js deploy/kubernetes            every resource its kustomization.yaml lists
//   node tests/deploy/kubernetes_schema.js FILE.yaml [FILE.yaml ...]     every object of these files
//
// The schema is the one kubernetes-models (npm, pinned in package.json and package-lock.json beside this
// file; scripts/setup.sh installs it) generated from the Kubernetes OpenAPI spec: each object goes
// through its kind's JSON-schema validator (types, formats such as int32 and quantities, enums, required
// fields). Those validators follow the OpenAPI spec, which does not forbid unknown fields (the API
// server drops or rejects them by its field validation, not by the schema), so a misspelt optional
// field would pass them silently. This script closes that gap from the same schema: it hands the
// validator a traced copy of the object and reports every field the validator never read. A JSON-schema
// validator reads exactly the properties its schema declares (and enumerates the keys of a map such as
// labels), so a field it never read is not in the schema: `kubectl apply --validate=strict` would refuse
// it. A field whose own schema is "anything" would also go unread and be reported: loud, never silent.
//
// Output: "ok FILE KIND/NAME" per valid object; "FILE:LINE: KIND/NAME: /json/pointer: what" per error, on
// stderr. Exit status 0 if every object is valid, 1 if any is not, 2 if the input cannot be read.
import { readFileSync, existsSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { LineCounter, isMap, isSeq, parseAllDocuments } from "yaml";

const here = dirname(fileURLToPath(import.meta.url));
const modelsPackage = JSON.parse(readFileSync(join(here, "node_modules/kubernetes-models/package.json"), "utf8"));
// kubernetes-models 5.0.0's change log: "Update to Kubernetes v1.36.0"; 5.1.0 keeps that schema.
const SCHEMA_VERSION = { "5.1.0": "1.36" }[modelsPackage.version] ?? "unknown (update SCHEMA_VERSION)";

// The files to check: a kustomization directory's resources, or the files named.
function inputFiles(args) {
  if (args.length === 1 && existsSync(join(args[0], "kustomization.yaml"))) {
    const kustomization = parseAllDocuments(readFileSync(join(args[0], "kustomization.yaml"), "utf8"))[0].toJS();
    return (kustomization.resources ?? []).map((r) => join(args[0], r));
  }
  return args;
}

// The model class of apiVersion/kind ("v1" is the core group), or null if the schema has none.
async function modelOf(apiVersion, kind) {
  if (typeof apiVersion !== "string" || typeof kind !== "string" || !/^[A-Za-z0-9]+$/.test(kind)) return null;
  try {
    const module = await import(`kubernetes-models/${apiVersion}/${kind}`);
    return module[kind] ?? null;
  } catch {
    return null;
  }
}

// A key as a JSON pointer segment (RFC 6901: ~ is ~0, / is ~1), and back.
const toSegment = (key) => key.replace(/~/g, "~0").replace(/\//g, "~1");
const fromSegment = (s) => s.replace(/~1/g, "/").replace(/~0/g, "~");

// A copy of `value` whose objects record the keys read from them ("read") and whether their keys were
// listed ("enumerated": the schema treats the object as a map). `records` collects one entry per object.
function traced(value, path, records) {
  if (Array.isArray(value)) return value.map((v, i) => traced(v, `${path}/${i}`, records));
  if (value === null || typeof value !== "object") return value;
  const record = { path, keys: Object.keys(value), read: new Set(), enumerated: false };
  records.push(record);
  const copy = {};
  for (const key of record.keys) copy[key] = traced(value[key], `${path}/${toSegment(key)}`, records);
  return new Proxy(copy, {
    get(target, key, receiver) {
      if (typeof key === "string") record.read.add(key);
      return Reflect.get(target, key, receiver);
    },
    has(target, key) {
      if (typeof key === "string") record.read.add(key);
      return Reflect.has(target, key);
    },
    ownKeys(target) {
      record.enumerated = true;
      return Reflect.ownKeys(target);
    },
  });
}

// The line of a JSON pointer in the YAML document: of its key (or sequence item), else of the deepest
// node that exists on the way (a required field that is missing: the object that lacks it).
function lineOf(doc, lineCounter, pointer) {
  const keys = pointer.split("/").slice(1).map(fromSegment).map((s) => (/^\d+$/.test(s) ? Number(s) : s));
  for (let n = keys.length; n >= 0; --n) {
    const parent = n <= 1 ? doc.contents : doc.getIn(keys.slice(0, n - 1), true);
    const node = n === 0 ? doc.contents
                         : isMap(parent) ? parent.items.find((pair) => pair.key?.value === keys[n - 1])?.key
                                         : isSeq(parent) ? parent.items[keys[n - 1]] : undefined;
    if (node?.range) return lineCounter.linePos(node.range[0]).line;
  }
  return 1;
}

// The errors of one object: [pointer, message] pairs.
function validateObject(Model, object) {
  const records = [];
  const root = traced(object, "", records);
  const errors = [];
  try {
    Model.prototype.validate.call(root);  // the kind's JSON-schema validator, on the traced copy
  } catch (e) {
    if (!Array.isArray(e.errors)) throw e;
    for (const err of e.errors) {
      if (err.keyword === "required") errors.push([`${err.instancePath}/${err.params.missingProperty}`, "required field missing"]);
      else errors.push([err.instancePath, err.message ?? err.keyword]);
    }
  }
  // Below a value of the wrong type the validator reads nothing: report the type, not its fields.
  // Below an unknown field nothing is read either: report the field, not what it holds. (Records are in
  // document order, an object before the objects inside it.)
  const silenced = errors.map(([p]) => p);
  const under = (path) => silenced.some((p) => path === p || path.startsWith(`${p}/`));
  for (const record of records) {
    if (record.enumerated || under(record.path)) continue;
    for (const key of record.keys) {
      if (record.read.has(key)) continue;
      const pointer = `${record.path}/${toSegment(key)}`;
      errors.push([pointer, `unknown field "${key}" (not in the Kubernetes ${SCHEMA_VERSION} schema)`]);
      silenced.push(pointer);
    }
  }
  return errors;
}

async function main() {
  const args = process.argv.slice(2);
  if (args.length === 0) {
    console.error("usage: node kubernetes_schema.js KUSTOMIZATION_DIR | FILE.yaml...");
    return 2;
  }
  console.log(`kubernetes-models ${modelsPackage.version}, Kubernetes ${SCHEMA_VERSION} schema`);
  let invalid = 0, objects = 0;
  for (const file of inputFiles(args)) {
    let text;
    try {
      text = readFileSync(file, "utf8");
    } catch (e) {
      console.error(`${file}: cannot read: ${e.message}`);
      return 2;
    }
    const lineCounter = new LineCounter();
    // YAML 1.1, as Kubernetes reads manifests (sigs.k8s.io/yaml): defaultMode: 0440 is octal.
    for (const doc of parseAllDocuments(text, { version: "1.1", lineCounter })) {
      if (doc.errors.length) {
        console.error(`${file}: not YAML: ${doc.errors[0].message}`);
        return 2;
      }
      const object = doc.toJS();
      if (object === null || object === undefined) continue;
      ++objects;
      const name = `${object.kind}/${object.metadata?.name ?? "(no name)"}`;
      const Model = await modelOf(object.apiVersion, object.kind);
      const errors = Model ? validateObject(Model, object)
                           : [["", `no schema for apiVersion "${object.apiVersion}" kind "${object.kind}"`]];
      for (const [pointer, message] of errors)
        console.error(`${file}:${lineOf(doc, lineCounter, pointer)}: ${name}: ${pointer || "/"}: ${message}`);
      if (errors.length) ++invalid;
      else console.log(`ok ${file} ${name}`);
    }
  }
  console.log(`${objects} objects, ${invalid} invalid`);
  return invalid ? 1 : 0;
}

process.exitCode = await main();
