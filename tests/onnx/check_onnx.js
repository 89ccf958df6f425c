// Runs an exported policy in ONNX Runtime (onnxruntime-node) on observations recorded from real
// rollouts and compares its outputs with libtorch's (tests/onnx/record_rollouts.cc).
//   node check_onnx.js MODEL SIDECAR RECORD_FOLDER [TOLERANCE]
// Prints the figures; exits 1 when an output differs from libtorch by more than TOLERANCE
// (default 1e-5; values are compared relative to max(1, |value|)).
'use strict';
const fs = require('fs');
const path = require('path');

let ort;
try {
  ort = require('onnxruntime-node');
} catch (error) {
  console.error(`FAIL: onnxruntime-node is not installed in ${path.join(__dirname, 'node_modules')}` +
                ` (${error.code || error.message}); run deploy/setup.sh, or` +
                ` npm ci --ignore-scripts --prefix ${__dirname}`);
  process.exit(1);
}

function fail(message) {
  console.error(`FAIL: ${message}`);
  process.exit(1);
}

function floats(file) {
  const bytes = fs.readFileSync(file);
  return new Float32Array(bytes.buffer, bytes.byteOffset, bytes.length / 4);
}

async function main() {
  const [modelPath, sidecarPath, recordFolder, toleranceText] = process.argv.slice(2);
  const tolerance = toleranceText ? Number(toleranceText) : 1e-5;
  const sidecar = JSON.parse(fs.readFileSync(sidecarPath, 'utf8'));
  const O = sidecar.observation.size, A = sidecar.action.size;
  const wantValue = sidecar.model.outputs.some((o) => o.name === 'value');

  const options = {intraOpNumThreads: 1, interOpNumThreads: 1, executionMode: 'sequential'};
  const session = await ort.InferenceSession.create(modelPath, options);
  const outputs = wantValue ? ['action', 'value'] : ['action'];
  if (JSON.stringify(session.inputNames) !== JSON.stringify(['observation'])) {
    fail(`inputs ${session.inputNames}, expected observation`);
  }
  if (JSON.stringify(session.outputNames) !== JSON.stringify(outputs)) {
    fail(`outputs ${session.outputNames}, expected ${outputs}`);
  }

  const observations = floats(path.join(recordFolder, 'observations.f32'));
  const actions = floats(path.join(recordFolder, 'actions.f32'));
  const values = floats(path.join(recordFolder, 'values.f32'));
  const N = observations.length / O;
  if (!Number.isInteger(N) || actions.length !== N * A || values.length !== N) {
    fail(`recorded sizes do not fit observation ${O} and action ${A}`);
  }
  if (N < 1000) fail(`only ${N} recorded observations, need at least 1000`);

  // Every observation in one batch (the dynamic batch dimension), then one at a time.
  const batch = await session.run({observation: new ort.Tensor('float32', observations, [N, O])});
  if (JSON.stringify(batch.action.dims) !== JSON.stringify([N, A])) {
    fail(`action dims ${batch.action.dims}, expected [${N}, ${A}]`);
  }
  let actionDiff = 0, valueDiff = 0, largestAction = 0;
  for (let i = 0; i < N * A; ++i) {
    actionDiff = Math.max(actionDiff, Math.abs(batch.action.data[i] - actions[i]));
    largestAction = Math.max(largestAction, Math.abs(actions[i]));
  }
  if (wantValue) {
    if (JSON.stringify(batch.value.dims) !== JSON.stringify([N, 1])) {
      fail(`value dims ${batch.value.dims}, expected [${N}, 1]`);
    }
    for (let i = 0; i < N; ++i) {
      const d = Math.abs(batch.value.data[i] - values[i]) / Math.max(1, Math.abs(values[i]));
      valueDiff = Math.max(valueDiff, d);
    }
  }

  const times = [];
  let singleDiff = 0;
  for (let i = 0; i < N; ++i) {
    const feed = {observation: new ort.Tensor('float32', observations.subarray(i * O, (i + 1) * O), [1, O])};
    const start = process.hrtime.bigint();
    const result = await session.run(feed, ['action']);
    times.push(Number(process.hrtime.bigint() - start) / 1000);
    for (let a = 0; a < A; ++a) {
      singleDiff = Math.max(singleDiff, Math.abs(result.action.data[a] - actions[i * A + a]));
    }
  }
  times.sort((x, y) => x - y);
  const median = times[Math.floor(times.length / 2)];

  console.log(`onnx: model ${fs.statSync(modelPath).size} bytes, opset ${sidecar.model.opset}; ` +
              `${N} recorded observations, actions up to ${largestAction.toFixed(3)} in size`);
  console.log(`onnx: max |action - libtorch| = ${actionDiff.toExponential(2)} (batch of ${N}), ` +
              `${singleDiff.toExponential(2)} (batch 1)` +
              (wantValue ? `; max |value - libtorch| / max(1, |value|) = ${valueDiff.toExponential(2)}` : ''));
  console.log(`onnx: ONNX Runtime ${require('onnxruntime-node/package.json').version}, batch 1, ` +
              `one thread: median ${median.toFixed(1)} us per step over ${N} calls`);
  if (!(actionDiff <= tolerance && singleDiff <= tolerance && valueDiff <= tolerance)) {
    fail(`outputs differ from libtorch by more than ${tolerance}`);
  }
  if (largestAction < 0.01) fail('the recorded actions are all near zero: nothing was compared');
}

main().catch((error) => fail(error.stack || error));
