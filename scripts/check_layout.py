#!/usr/bin/env python3
"""Checks that includes run only downwards:

    apps -> run -> strategies -> core <- plugins
    apps -> interop           -> core

interop (data exchange with other tools: CalculiX, SID, FE geometry, running programs) builds on
core's public headers only; core, plugins, strategies and the run layer never include it. Inside
core the parts are ranked base <- model <- linalg <- response <- gramians <- measures <- plugin.
Prints every include that runs the other way and exits 1 if there is one.
Run from anywhere: python3 scripts/check_layout.py [ROOT]   (default: this script's repository)
       python3 scripts/check_layout.py --self-test   (each kind of violation is caught, a clean
                                                      tree passes)
"""
import os
import re
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Rank of each part of core; a file may include its own part and parts of lower rank.
CORE_RANK = {'base': 0, 'model': 1, 'linalg': 2, 'response': 3, 'gramians': 4, 'measures': 5,
             'plugin': 6}
# The layers (top-level folders) and the other layers each may include, through their public
# headers (ecmor/<core part>/, ecmor/interop/, ecmor/strategies/, ecmor/run/).
MAY_INCLUDE = {
    'core': set(),
    'interop': {'core'},
    'plugins': {'core'},
    'strategies': {'core'},
    'run': {'core', 'strategies'},
    'apps': {'core', 'interop', 'strategies', 'run'},
}
LAYERS = tuple(MAY_INCLUDE)
INCLUDE = re.compile(r'\s*#\s*include\s+"([^"]+)"')


def core_part(path):
    """The part of core a file belongs to, or None."""
    for prefix in ('core/include/ecmor/', 'core/src/'):
        if path.startswith(prefix):
            rest = path[len(prefix):].split('/')
            return rest[0] if len(rest) > 1 and rest[0] in CORE_RANK else None
    return None


def included_part(name):
    """The part of core an include names ("ecmor/linalg/x.hpp" or, in core/src, "linalg/x.hpp")."""
    parts = name.split('/')
    if parts[0] == 'ecmor' and len(parts) == 3 and parts[1] in CORE_RANK:
        return parts[1]
    if len(parts) == 2 and parts[0] in CORE_RANK:
        return parts[0]
    return None


def private_core_header(name):
    """True for a header of core/src ("linalg/qz_solver.hpp"), which only core may include."""
    parts = name.split('/')
    return len(parts) == 2 and parts[0] in CORE_RANK


def included_layer(name):
    """The layer whose header an include names, or None (the file's own or a library's)."""
    if name.startswith('ecmor/strategies/'):
        return 'strategies'
    if name.startswith('ecmor/run/'):
        return 'run'
    if name.startswith('ecmor/interop/'):
        return 'interop'
    if name in ('ecmor/export.hpp', 'ecmor/version.hpp') or included_part(name):
        return 'core'
    if 'apps/' in name or name == 'commands.hpp':
        return 'apps'
    return None


def layer(path):
    for top in LAYERS:
        if path.startswith(top + '/'):
            return top
    return None


def check_file(root, rel):
    """The layering problems of one file (path relative to root)."""
    found = []
    top = layer(rel)
    if top == 'core' and core_part(rel) is None and not rel.endswith('version.hpp.in'):
        found.append(f'{rel}: a core file outside the parts {sorted(CORE_RANK)}')
    with open(os.path.join(root, rel), encoding='utf-8') as fh:
        for number, line in enumerate(fh, 1):
            m = INCLUDE.match(line)
            if not m:
                continue
            name = m.group(1)
            where = f'{rel}:{number}: includes "{name}"'
            target_layer = included_layer(name)
            if target_layer and target_layer != top and target_layer not in MAY_INCLUDE[top]:
                found.append(f'{where}: {top} must not include {target_layer} '
                             f'({top} may include {", ".join(sorted(MAY_INCLUDE[top])) or "nothing else"})')
            if top != 'core' and private_core_header(name):
                found.append(f'{where}: a private header of core (core/src); {top} uses core\'s '
                             f'public headers only')
            part, target = core_part(rel), included_part(name)
            if part and target and CORE_RANK[target] > CORE_RANK[part]:
                found.append(f'{where}: core/{part} must not include core/{target}')
            if top == 'core' and name.startswith('ecmor/') and target is None and \
                    name not in ('ecmor/export.hpp', 'ecmor/version.hpp') and \
                    target_layer is None:
                found.append(f'{where}: not a header of a part of core')
    return found


def problems(root=ROOT):
    found = []
    for top in LAYERS:
        for dirpath, _, files in os.walk(os.path.join(root, top)):
            for f in sorted(files):
                if f.endswith(('.hpp', '.cpp', '.h')):
                    found += check_file(root, os.path.relpath(os.path.join(dirpath, f), root))
    return found


def self_test():
    """The check must be able to fail: a scratch tree with one violation per file has each file
    reported, and a tree of allowed includes passes."""
    bad = {
        'core/src/model/a.cpp': 'ecmor/interop/sid.hpp',             # core -> interop
        'core/include/ecmor/base/b.hpp': 'ecmor/linalg/eigensolver.hpp',  # part ranks
        'core/src/body/c.cpp': 'ecmor/base/types.hpp',               # core outside its parts
        'plugins/p/d.cpp': 'ecmor/interop/calculix.hpp',             # plugins -> interop
        'plugins/p/e.cpp': 'ecmor/strategies/config.hpp',            # plugins -> strategies
        'strategies/src/f.cpp': 'ecmor/interop/fe_geometry.hpp',     # strategies -> interop
        'strategies/src/j.cpp': 'ecmor/run/driver.hpp',              # strategies -> run
        'run/src/k.cpp': 'ecmor/interop/sid.hpp',                    # run -> interop
        'plugins/p/l.cpp': 'ecmor/run/config.hpp',                   # plugins -> run
        'interop/src/g.cpp': 'ecmor/strategies/driver.hpp',          # interop -> strategies
        'interop/src/h.cpp': 'linalg/qz_solver.hpp',                 # core's private header
        'interop/src/i.cpp': 'commands.hpp',                         # interop -> apps
    }
    good = {
        'apps/ecmor/a.cpp': ['ecmor/interop/sid.hpp', 'ecmor/run/driver.hpp',
                             'ecmor/strategies/strategy.hpp', 'ecmor/model/model.hpp',
                             'commands.hpp'],
        'run/src/f.cpp': ['ecmor/run/config.hpp', 'ecmor/strategies/strategy.hpp',
                          'ecmor/base/error.hpp', 'acceptance.hpp'],
        'interop/src/b.cpp': ['ecmor/interop/sid.hpp', 'ecmor/linalg/rigid_body.hpp',
                              'ecmor/export.hpp', 'text_fields.hpp'],
        'interop/include/ecmor/interop/c.hpp': ['ecmor/interop/export.hpp',
                                                'ecmor/model/model.hpp'],
        'plugins/p/d.cpp': ['ecmor/plugin/plugin.hpp', 'local.hpp'],
        'core/src/linalg/e.cpp': ['ecmor/model/model.hpp', 'linalg/qz_solver.hpp'],
    }

    def write(root, rel, includes):
        path = os.path.join(root, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, 'w', encoding='utf-8') as f:
            f.write(''.join(f'#include "{name}"\n' for name in includes))

    with tempfile.TemporaryDirectory() as d:
        for rel, name in bad.items():
            write(d, rel, [name])
        flagged = {p.split(':')[0] for p in problems(d)}
    with tempfile.TemporaryDirectory() as d:
        for rel, names in good.items():
            write(d, rel, names)
        clean = problems(d)
    missed = sorted(set(bad) - flagged)
    if missed or clean:
        print(f'check_layout: self-test FAILED: not flagged {missed}; flagged in the clean tree '
              f'{clean}', file=sys.stderr)
        return 1
    print(f'check_layout: self-test passed ({len(bad)} violations caught, clean tree passes)')
    return 0


def main():
    if sys.argv[1:] == ['--self-test']:
        return self_test()
    root = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else ROOT
    issues = problems(root)
    for p in issues:
        print(p)
    print(f'check_layout: {len(issues)} include(s) against the layering' if issues
          else 'check_layout: every include runs downwards')
    return 1 if issues else 0


if __name__ == '__main__':
    sys.exit(main())
