#!/usr/bin/env python3
"""Import cycles between tumble's source files (issue 29's layering check).

Reads every `crate::a::b` and `super::a` path in src/ (comments skipped), resolves each to the
module file it names, and prints the strongly connected components of the file graph: first
those between top-level modules, then those whose files lie in different folders. Exits 1 if
any component spans top-level modules or folders (a folder's own small family, files of one
folder importing each other, is allowed and listed apart).
"""
import collections, os, re, sys

SRC = os.environ.get("TUMBLE_SRC") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")


def module_of(path):
    rel = os.path.relpath(path, SRC)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return tuple(rel)


files = {}
for root, _, names in os.walk(SRC):
    for n in names:
        if n.endswith(".rs"):
            p = os.path.join(root, n)
            files[module_of(p)] = p

def resolve(parts):
    for k in range(len(parts), 0, -1):
        if tuple(parts[:k]) in files:
            return tuple(parts[:k])
    return None

graph = collections.defaultdict(set)
for mod, path in files.items():
    is_mod_rs = os.path.basename(path) in ("mod.rs", "lib.rs", "main.rs")
    for line in open(path, encoding="utf-8"):
        s = line.strip()
        if s.startswith("//"):
            continue
        s = s.split("//")[0]
        for m in re.finditer(r"\bcrate((?:::[a-z_][a-z0-9_]*)+)", s):
            t = resolve(m.group(1).strip(":").split("::"))
            if t and t != mod and t != ():
                graph[mod].add(t)
        for m in re.finditer(r"\b((?:super::)+)((?:[a-z_][a-z0-9_]*::?)*)", s):
            ups = m.group(1).count("super")
            base = list(mod if is_mod_rs else mod)
            base = base[: len(base) - ups] if ups <= len(base) else []
            t = resolve(base + [p for p in m.group(2).split("::") if p])
            if t and t != mod and t != ():
                graph[mod].add(t)

# Tarjan's strongly connected components.
index, low, stack, on, comps = {}, {}, [], set(), []
def strong(v):
    index[v] = low[v] = len(index); stack.append(v); on.add(v)
    for w in graph[v]:
        if w not in index:
            strong(w); low[v] = min(low[v], low[w])
        elif w in on:
            low[v] = min(low[v], index[w])
    if low[v] == index[v]:
        comp = []
        while True:
            w = stack.pop(); on.discard(w); comp.append(w)
            if w == v:
                break
        if len(comp) > 1:
            comps.append(sorted(comp))
sys.setrecursionlimit(10000)
for v in list(files):
    if v not in index:
        strong(v)

def folder(m):
    p = files[m]
    return os.path.dirname(p)

bad = 0
for comp in comps:
    tops = {m[0] for m in comp}
    folders = {folder(m) for m in comp}
    # A folder's family: its files and the folder's own mod.rs (which lives one level up).
    family = len(tops) == 1 and len({m[: len(m) - 1] if not files[m].endswith("mod.rs") else m for m in comp}) == 1
    kind = "family" if family else ("TOP-LEVEL" if len(tops) > 1 else "CROSS-FOLDER")
    if not family:
        bad += 1
    print(f"{kind}: " + " <-> ".join("::".join(m) for m in comp))
print(f"{len(comps)} cycles, {bad} outside a folder's family")
sys.exit(1 if bad else 0)
