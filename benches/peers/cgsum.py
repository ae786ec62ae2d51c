"""Read a callgrind output file: totals, self cost per function and per source file, inclusive
cost per function (benches/peers/profile.sh's tables, PROFILE.md).

    python3 cgsum.py top FILE [N]          # the N costliest functions, inclusive and self
    python3 cgsum.py files FILE [N]        # self cost by source file (inlined code counts where it is written)
    python3 cgsum.py objects FILE          # self cost by object (binary, library, JIT code)
    python3 cgsum.py mix FILE [N]          # instruction mix: scalar f64, packed f32 × 8, … (needs --dump-instr=yes)

Functions are named as callgrind names them (demangled); a function met in several files (its
inlined parts) is one entry. Inclusive cost = self + the costs of its calls to other functions
(callgrind's `calls=` lines; a recursion level, `f'2`, is another function, so recursive calls
count once). Only the standard library is used: `profile.sh` imports this module.
"""

import re
import sys
from collections import defaultdict

_NAME = re.compile(r"^\((\d+)\)(?: (.*))?$")


class Profile:
    def __init__(self, path):
        self.path = path
        self.events = []
        self.summary = None
        self.cmd = ""
        self.self_fn = defaultdict(lambda: None)  # fn -> [costs]
        self.self_file = {}  # source file -> [costs]
        self.self_obj = {}  # object -> [costs]
        self.calls = defaultdict(lambda: None)  # fn -> [costs of its calls to other functions]
        self.fn_obj = {}
        self.instr = {}  # (object, fn) -> {address: Ir}, when the file has instruction positions
        self._read()

    def _add(self, table, key, costs):
        cur = table.get(key)
        if cur is None:
            table[key] = list(costs)
        else:
            for i, c in enumerate(costs):
                cur[i] += c

    def _read(self):
        names = {"fl": {}, "fn": {}, "ob": {}}
        kinds = {"fl": "fl", "fi": "fl", "fe": "fl", "cfl": "fl", "cfi": "fl", "fn": "fn", "cfn": "fn", "ob": "ob", "cob": "ob"}

        def name(kind, value):
            m = _NAME.match(value)
            table = names[kinds[kind]]
            if not m:
                return value
            if m.group(2) is not None:
                table[m.group(1)] = m.group(2)
                return m.group(2)
            return table.get(m.group(1), "?")

        n = 0
        by_instr = False
        addr = 0
        instr = {}
        fn = ob = src = None
        call_fn = None
        pending_call = False
        self_fn, self_file, self_obj, calls, calls_to = {}, {}, {}, {}, {}
        with open(self.path, errors="replace") as f:
            for line in f:
                line = line.rstrip("\n")
                if not line:
                    continue
                c = line[0]
                if c.isdigit() or c in "+-*":
                    parts = line.split()
                    if by_instr:
                        a = parts[0]
                        if a.startswith("0x"):
                            addr = int(a, 16)
                        elif a[0] in "+-":
                            addr += int(a)
                        elif a != "*":
                            addr = int(a)
                        parts = parts[1:]
                    costs = [int(x) for x in parts[1:]] if len(parts) > 1 else []
                    if not n:
                        continue
                    costs = (costs + [0] * n)[:n]
                    if pending_call:
                        pending_call = False
                        if call_fn != fn:
                            self._add(calls, fn, costs)
                            self._add(calls_to, (fn, call_fn), costs[:1])
                    else:
                        self._add(self_fn, fn, costs)
                        self._add(self_file, src, costs)
                        self._add(self_obj, ob, costs)
                        if by_instr:
                            d = instr.setdefault((ob, fn), {})
                            d[addr] = d.get(addr, 0) + costs[0]
                    continue
                key, _, value = line.partition("=")
                if key in ("fl", "fi", "fe"):
                    src = name(key, value)
                elif key == "fn":
                    fn = name(key, value)
                    self.fn_obj.setdefault(fn, ob)
                elif key == "ob":
                    ob = name(key, value)
                elif key in ("cfl", "cfi", "cob"):
                    name(key, value)
                elif key == "cfn":
                    call_fn = name(key, value)
                elif key == "calls":
                    pending_call = True
                elif line.startswith("positions:"):
                    by_instr = "instr" in line.split()[1:]
                elif line.startswith("events:"):
                    self.events = line.split()[1:]
                    n = len(self.events)
                elif line.startswith("summary:") or line.startswith("totals:"):
                    self.summary = [int(x) for x in line.split()[1:]]
                elif line.startswith("cmd:"):
                    self.cmd = line[4:].strip()
        self.self_fn, self.self_file, self.self_obj, self.calls = self_fn, self_file, self_obj, calls
        self.instr = instr
        self.calls_to = calls_to  # (caller, callee) -> [Ir of those calls, inclusive]
        if self.summary is None:
            tot = [0] * n
            for v in self_fn.values():
                for i, x in enumerate(v):
                    tot[i] += x
            self.summary = tot

    def total(self, event="Ir"):
        return self.summary[self.events.index(event)] if event in self.events else 0

    def inclusive(self, fn, event="Ir"):
        i = self.events.index(event)
        s = self.self_fn.get(fn)
        c = self.calls.get(fn)
        return (s[i] if s else 0) + (c[i] if c else 0)

    def inclusive_matching(self, pattern, event="Ir"):
        """Largest inclusive cost among functions whose name matches `pattern` (a regex), and its
        name: the outermost of nested matches, so nothing is counted twice."""
        rx = re.compile(pattern)
        best, best_fn = 0, None
        for fn in set(self.self_fn) | set(self.calls):
            if fn and rx.search(fn):
                v = self.inclusive(fn, event)
                if v > best:
                    best, best_fn = v, fn
        return best, best_fn

    def sum_inclusive(self, pattern, event="Ir"):
        """Sum of the inclusive costs of the functions matching `pattern` (for entries that do not
        call one another, e.g. the several monomorphised copies of one method)."""
        rx = re.compile(pattern)
        return sum(self.inclusive(fn, event) for fn in set(self.self_fn) | set(self.calls) if fn and rx.search(fn))

    def outer_inclusive(self, pattern):
        """Ir of the functions matching `pattern`, each call counted once: their inclusive costs
        less the costs of the calls they make to one another (Ir only)."""
        rx = re.compile(pattern)
        fns = {fn for fn in set(self.self_fn) | set(self.calls) if fn and rx.search(fn)}
        total = sum(self.inclusive(fn) for fn in fns)
        for (a, b), v in self.calls_to.items():
            if a in fns and b in fns:
                total -= v[0]
        return total

    def self_matching(self, pattern, event="Ir", table=None):
        rx = re.compile(pattern)
        i = self.events.index(event)
        t = self.self_fn if table is None else table
        return sum(v[i] for k, v in t.items() if k and rx.search(k))


# --- instruction mix ------------------------------------------------------------------------------
# Each executed instruction (callgrind's count per address, --dump-instr=yes) is looked up in the
# object's disassembly (objdump, AT&T syntax) and put in one class. JIT code (object "???") has no
# file to disassemble and stays unclassified.
CLASSES = ["f32 x16", "f32 x8", "f32 x4", "f32 scalar", "f64 x8", "f64 x4", "f64 x2", "f64 scalar", "int SIMD", "other"]


def classify(mnemonic, operands):
    m = mnemonic.split(".")[0]
    width = 512 if "zmm" in operands else 256 if "ymm" in operands else 128 if "xmm" in operands else 0
    if m in ("vbroadcastss",):
        m = "vbroadcastps"
    if m in ("vbroadcastsd",):
        m = "vbroadcastpd"
    if width and m.endswith("ps"):
        return {512: "f32 x16", 256: "f32 x8", 128: "f32 x4"}[width]
    if width and m.endswith("pd"):
        return {512: "f64 x8", 256: "f64 x4", 128: "f64 x2"}[width]
    if width and (m.endswith("ss") or m.endswith("2ss") or m.endswith("ssl") or m.endswith("ssq")):
        return "f32 scalar"
    if width and (m.endswith("sd") or m.endswith("2sd") or m.endswith("sdl") or m.endswith("sdq")):
        return "f64 scalar"
    if width:
        return "int SIMD"
    return "other"


_DISASSEMBLY = {}


def disassembly(path, wanted):
    """{address: class} for the addresses in `wanted`, from objdump of `path` (each object's
    classes are kept for the next call)."""
    known = _DISASSEMBLY.setdefault(path, {})
    missing = set(wanted) - set(known)
    if missing:
        known.update(_disassembly(path, missing))
    return known


def _disassembly(path, wanted):
    import subprocess

    out = {}
    try:
        proc = subprocess.Popen(["objdump", "-d", "--no-show-raw-insn", "-w", path], stdout=subprocess.PIPE, text=True, errors="replace")
    except OSError:
        return out
    for line in proc.stdout:
        # "  1234:\tvmulpd %ymm1,%ymm2,%ymm3"
        head, sep, rest = line.partition(":\t")
        if not sep:
            continue
        try:
            a = int(head.strip(), 16)
        except ValueError:
            continue
        if a not in wanted:
            continue
        parts = rest.strip().split(None, 1)
        if not parts:
            continue
        out[a] = classify(parts[0], parts[1] if len(parts) > 1 else "")
    proc.wait()
    return out


def mix(p, min_share=0.005, base=None):
    """{object: {class: Ir}} and {fn: {class: Ir}} over objects holding ≥ min_share of the Ir.
    With `base`, its counts are taken off address by address first (a run that does the same
    less the work of interest: what is left is that work)."""
    import os

    instr = p.instr
    if base is not None:
        instr = {k: dict(v) for k, v in p.instr.items()}
        for k, d in base.instr.items():
            t = instr.setdefault(k, {})
            for a, v in d.items():
                t[a] = t.get(a, 0) - v
    tot = sum(sum(d.values()) for d in instr.values())
    by_obj_addr = {}
    for (ob, fn), d in instr.items():
        t = by_obj_addr.setdefault(ob, {})
        for a, v in d.items():
            t[a] = t.get(a, 0) + v
    obj_mix, fn_mix = {}, {}
    for ob, d in by_obj_addr.items():
        if sum(d.values()) < min_share * tot:
            continue
        cls = disassembly(ob, set(d)) if ob and os.path.isfile(ob) else {}
        om = obj_mix.setdefault(ob, dict.fromkeys(CLASSES + ["unknown"], 0))
        for a, v in d.items():
            om[cls.get(a, "unknown")] += v
        for (o2, fn), fd in instr.items():
            if o2 != ob:
                continue
            fm = fn_mix.setdefault(fn, dict.fromkeys(CLASSES + ["unknown"], 0))
            for a, v in fd.items():
                fm[cls.get(a, "unknown")] += v
    return obj_mix, fn_mix


def add_mix(a, b):
    out = dict(a)
    for k, v in b.items():
        out[k] = out.get(k, 0) + v
    return out


def _fmt(x):
    return f"{x / 1e6:10.2f} M"


def main(argv):
    if len(argv) < 3:
        sys.exit(__doc__)
    what, path = argv[1], argv[2]
    top = int(argv[3]) if len(argv) > 3 else 40
    p = Profile(path)
    tot = p.total()
    print(f"{path}: {p.cmd}")
    print("totals: " + ", ".join(f"{e} {v:,}" for e, v in zip(p.events, p.summary)))
    if what == "top":
        fns = set(p.self_fn) | set(p.calls)
        inc = sorted(((p.inclusive(f), f) for f in fns if f), reverse=True)[:top]
        print("-- inclusive Ir")
        for v, f in inc:
            print(f"{_fmt(v)} {100 * v / tot:5.1f} %  {f[:200]}")
        slf = sorted(((v[0], f) for f, v in p.self_fn.items() if f), reverse=True)[:top]
        print("-- self Ir")
        for v, f in slf:
            print(f"{_fmt(v)} {100 * v / tot:5.1f} %  {f[:200]}")
    elif what == "files":
        for f, v in sorted(p.self_file.items(), key=lambda kv: -kv[1][0])[:top]:
            print(f"{_fmt(v[0])} {100 * v[0] / tot:5.1f} %  {f}")
    elif what == "mix":
        om, fm = mix(p)
        keys = CLASSES + ["unknown"]
        print("share of each object's executed instructions: " + " | ".join(keys))
        for ob, m in sorted(om.items(), key=lambda kv: -sum(kv[1].values())):
            t = sum(m.values()) or 1
            print(f"{_fmt(t)}  " + " ".join(f"{100 * m[k] / t:5.1f}" for k in keys) + f"  {ob}")
        print("-- functions")
        for fn, m in sorted(fm.items(), key=lambda kv: -sum(kv[1].values()))[:top]:
            t = sum(m.values()) or 1
            print(f"{_fmt(t)}  " + " ".join(f"{100 * m[k] / t:5.1f}" for k in keys) + f"  {fn[:120]}")
    elif what == "objects":
        for f, v in sorted(p.self_obj.items(), key=lambda kv: -kv[1][0])[:top]:
            print(f"{_fmt(v[0])} {100 * v[0] / tot:5.1f} %  {f}")
    else:
        sys.exit(__doc__)


if __name__ == "__main__":
    main(sys.argv)
