// Faster, not different: rp2040js's Cortex-M0+ core with its instruction decode indexed, and its
// SRAM stores before the peripheral lookup. Every figure the runner gives stays the same to the
// cycle (tests/test_pico_decoder.py runs both cores side by side and compares).
//
// CortexM0Core.executeInstruction (rp2040js 1.4.1, dist/esm/cortex-m0-core.js) decodes a Thumb
// opcode with one chain of 83 `if (opcode >> k === pattern)` tests in alphabetical order: an
// STR or a PUSH is found after 60 failed tests. Here the same source is cut at load into that
// chain's branches, and a `switch (opcode >> 11)` on the top five bits holds, for each of its 32
// values, the branches that can match an opcode there, in the chain's order (so the first match
// is the same branch). Outside the 32-bit encodings (top bits 11101, 11110, 11111) opcode2 is 0,
// so which branches can match is exact; in those three a test on opcode2 counts as possible.
// Nothing is rewritten by hand: a source that is not cut as expected leaves the stock core (with
// a line on stderr), as does FLUXCAL_PICO_DECODER=stock.
import fs from 'node:fs';

const PREFIX = 'export class CortexM0Core';

// the text from `open` (a '(' or '{') to its match, skipping strings, templates and comments
function matching(src, open) {
  const close = { '(': ')', '{': '}' };
  const stack = [];
  for (let i = open; i < src.length; i++) {
    const c = src[i];
    if (c === '/' && src[i + 1] === '/') { i = src.indexOf('\n', i); continue; }
    if (c === '/' && src[i + 1] === '*') { i = src.indexOf('*/', i) + 1; continue; }
    if (c === "'" || c === '"') {
      for (i++; src[i] !== c; i++) if (src[i] === '\\') i++;
      continue;
    }
    if (c === '`') {                     // a template: its ${...} parts hold braces of their own
      for (i++; src[i] !== '`'; i++) {
        if (src[i] === '\\') i++;
        else if (src[i] === '$' && src[i + 1] === '{') i = matching(src, i + 1);
      }
      continue;
    }
    if (c === '(' || c === '{') stack.push(close[c]);
    else if (c === ')' || c === '}') {
      if (stack.pop() !== c) throw new Error(`unbalanced ${c} at ${i}`);
      if (!stack.length) return i;
    }
  }
  throw new Error('unterminated');
}

const skipSpace = (src, i) => {
  for (;;) {
    while (/\s/.test(src[i])) i++;
    if (src.startsWith('//', i)) i = src.indexOf('\n', i);
    else return i;
  }
};

// executeInstruction's source: [before the chain, [{cond, body}], the final else body, after]
function cut(src) {
  const start = src.indexOf('    executeInstruction() {');
  if (start < 0) throw new Error('no executeInstruction');
  const open = src.indexOf('{', start);
  const fn = src.slice(open + 1, matching(src, open));
  const first = fn.indexOf('if (opcode >>');
  if (first < 0) throw new Error('no executeInstruction chain');
  const branches = [];
  let i = first, rest = null;
  for (;;) {
    const p = fn.indexOf('(', i);
    const pEnd = matching(fn, p);
    const b = skipSpace(fn, pEnd + 1);
    if (fn[b] !== '{') throw new Error('a branch without a block');
    const bEnd = matching(fn, b);
    branches.push({ cond: fn.slice(p + 1, pEnd), body: fn.slice(b, bEnd + 1) });
    i = skipSpace(fn, bEnd + 1);
    if (!fn.startsWith('else', i)) throw new Error('a chain without its final else');
    i = skipSpace(fn, i + 4);
    if (fn.startsWith('if', i)) continue;
    const eEnd = matching(fn, i);
    rest = { last: fn.slice(i, eEnd + 1), after: fn.slice(eEnd + 1) };
    break;
  }
  return { before: fn.slice(0, first), branches, ...rest };
}

// the top-level `&&` terms of a condition
function terms(cond) {
  const out = [];
  let depth = 0, from = 0;
  for (let i = 0; i < cond.length; i++) {
    if (cond[i] === '(') depth++;
    else if (cond[i] === ')') depth--;
    else if (depth === 0 && cond.startsWith('&&', i)) { out.push(cond.slice(from, i)); from = i + 2; i++; }
  }
  return out.concat(cond.slice(from));
}

// can `cond` hold for an opcode whose top five bits are `top`? (opcode2: 0 outside the 32-bit
// encodings; inside them a term on opcode2, or a condition with a top-level ||, may hold)
function possible(cond, top) {
  const wide = top >= 0b11101;
  let test = cond;
  if (wide && cond.includes('opcode2')) {
    if (cond.includes('||')) return true;
    test = terms(cond).map((t) => (t.includes('opcode2') ? 'true' : t)).join('&&');
  }
  const f = new Function('opcode', 'opcode2', `return !!(${test});`);
  for (let op = top << 11; op < (top + 1) << 11; op++) if (f(op, 0)) return true;
  return false;
}

// for each of the 32 values of the top five bits, the chain's branches that can match there
function buckets(chain) {
  const out = [];
  for (let top = 0; top < 32; top++) out.push(chain.branches.flatMap((b, k) => (possible(b.cond, top) ? [k] : [])));
  return out;
}

function indexedSource(chain, plan) {
  const cases = plan.map((mine, top) => {
    const ifs = mine.map((k, n) => `${n ? 'else ' : ''}if (${chain.branches[k].cond}) ${chain.branches[k].body}`);
    return `case ${top}: ${ifs.join('\n')}${mine.length ? '\nelse ' : ''}${chain.last}\nbreak;`;
  });
  return `${chain.before}switch (opcode >> 11) {\n${cases.join('\n')}\n}\n${chain.after}`;
}

// the module's own constants and helpers (the part before the class), for the new function
function prelude(src) {
  return src.slice(0, src.indexOf(PREFIX)).replace(/^import .*$/gm, '').replace(/^export /gm, '');
}

// { executeInstruction, chain, plan } from the core's source file; `imports`: what it imports
export function indexedCore(coreFile, imports) {
  const src = fs.readFileSync(coreFile, 'utf8');
  const chain = cut(src);
  const plan = buckets(chain);
  const names = Object.keys(imports);
  const make = new Function(...names, `${prelude(src)}\nreturn function executeInstruction() {${indexedSource(chain, plan)}};`);
  return { executeInstruction: make(...names.map((n) => imports[n])), chain, plan };
}

export function indexDecoder(coreFile, CortexM0Core, imports, say) {
  if (process.env.FLUXCAL_PICO_DECODER === 'stock') return false;
  try {
    CortexM0Core.prototype.executeInstruction = indexedCore(coreFile, imports).executeInstruction;
    return true;
  } catch (e) {
    say(`the indexed decoder was not made (${e.message}): the stock core runs`);
    return false;
  }
}

// RP2040.writeUint32 looks a peripheral up before it tries SRAM; the SRAM store first (no
// peripheral sits in SRAM's addresses, so the same store is done)
export function sramFirst(RP2040, RAM_START_ADDRESS) {
  if (process.env.FLUXCAL_PICO_DECODER === 'stock') return;
  const write = RP2040.prototype.writeUint32;
  RP2040.prototype.writeUint32 = function writeUint32(address, value) {
    const offset = (address >>> 0) - RAM_START_ADDRESS;
    if (offset >= 0 && offset + 3 < this.sram.length) this.sramView.setUint32(offset, value, true);
    else write.call(this, address, value);
  };
}
