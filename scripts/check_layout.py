#!/usr/bin/env python3
"""Checks that includes run only downwards: apps -> run -> strategies -> core <- plugins, and inside core
base <- model <- linalg <- response <- gramians <- measures <- {plugin, body}. Prints every include
that runs the other way and exits 1 if there is one. Run from anywhere: python3 scripts/check_layout.py
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Rank of each part of core; a file may include its own part and parts of lower rank.
CORE_RANK = {'base': 0, 'model': 1, 'linalg': 2, 'response': 3, 'gramians': 4, 'measures': 5,
             'plugin': 6, 'body': 6}
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


def layer(path):
    for top in ('core', 'strategies', 'run', 'plugins', 'apps'):
        if path.startswith(top + '/'):
            return top
    return None


def problems():
    found = []
    for top in ('core', 'strategies', 'run', 'plugins', 'apps'):
        for dirpath, _, files in os.walk(os.path.join(ROOT, top)):
            for f in files:
                if not f.endswith(('.hpp', '.cpp', '.h')):
                    continue
                full = os.path.join(dirpath, f)
                rel = os.path.relpath(full, ROOT)
                if top == 'core' and core_part(rel) is None and not rel.endswith('version.hpp.in'):
                    found.append(f'{rel}: a core file outside the parts {sorted(CORE_RANK)}')
                with open(full, encoding='utf-8') as fh:
                    for number, line in enumerate(fh, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        name = m.group(1)
                        where = f'{rel}:{number}: includes "{name}"'
                        if name.startswith('ecmor/strategies/') and top in ('core', 'plugins'):
                            found.append(f'{where}: {top} must not depend on strategies')
                        if name.startswith('ecmor/run/') and top in ('core', 'plugins', 'strategies'):
                            found.append(f'{where}: {top} must not depend on the run layer')
                        if top in ('core', 'plugins', 'strategies', 'run') and ('apps/' in name or
                                                                         name == 'commands.hpp'):
                            found.append(f'{where}: only apps include apps')
                        part, target = core_part(rel), included_part(name)
                        if part and target and CORE_RANK[target] > CORE_RANK[part]:
                            found.append(f'{where}: core/{part} must not include core/{target}')
                        if top == 'core' and name.startswith('ecmor/') and target is None and \
                                name not in ('ecmor/export.hpp', 'ecmor/version.hpp'):
                            found.append(f'{where}: not a header of a part of core')
    return found


if __name__ == '__main__':
    issues = problems()
    for p in issues:
        print(p)
    print(f'check_layout: {len(issues)} include(s) against the layering' if issues
          else 'check_layout: every include runs downwards')
    sys.exit(1 if issues else 0)
