#!/usr/bin/env python3
"""Checks that the project reads nothing from outside its repository: no tracked file may refer to
the folder `shared/` that sits beside some checkouts, however the path to it is spelled.
The models, references and data the project runs on live in it (models/, tests/, fuzz/corpus/).
Prints every offending line as FILE:LINE: TEXT and exits 1 if there is one.
Run from anywhere: python3 scripts/check_paths.py [ROOT]   (default: this script's repository)
       python3 scripts/check_paths.py --self-test   (each spelling is caught, a clean tree passes)
"""
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# A path that climbs out of the tree into the sibling folder shared/: dot-dot, a slash (or a
# backslash) and "shared"; the same built from pieces (".." / "shared"); or an absolute path to a
# shared/models folder. (This file spells none of them out, so that grep finds nothing here.)
UP = '..'

PATTERNS = [
    (re.compile(r'\.\.[/\\]+shared\b'), 'refers to the shared/ folder beside the checkout'),
    (re.compile(r'"\.\."\)?\s*/\s*"shared"'), 'builds a path to the shared/ folder beside the checkout'),
    (re.compile(r'(?<![\w.])/[\w.-]+/shared/models\b'), 'an absolute path to a shared/models folder'),
]
SELF = 'scripts/check_paths.py'


def tracked_files(root):
    """The files git tracks; every file of the tree (without build folders) when it is no checkout."""
    try:
        out = subprocess.run(['git', '-C', root, 'ls-files', '-z'], check=True,
                             capture_output=True).stdout
        return [f for f in out.decode().split('\0') if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, subdirs, names in os.walk(root):
            subdirs[:] = [s for s in subdirs if s != '.git' and not s.startswith('build')]
            files += [os.path.relpath(os.path.join(d, n), root) for n in names]
        return files


def self_test():
    """The check must be able to fail: every spelling in a scratch tree is reported, and a tree
    that names only its own models/ passes."""
    bad = [f'model: {{dir: {UP}/shared/models/lf10}}', f'load_model("{UP}/shared/models/" + name)',
           'fs::path(ECMOR_TEST_SOURCE_DIR) / ".." / "shared" / "models"',
           'fs::path("..") / "shared"', 'ecmor info /work/shared/models/iss', UP + r'\\shared\\x']
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, 'bad.txt'), 'w') as f:
            f.write('\n'.join(bad + ['model: {dir: models/lf10}', 'shared_ptr<T> p']) + '\n')
        found = scan(d, ['bad.txt'])
        with open(os.path.join(d, 'good.txt'), 'w') as f:
            f.write('model: {dir: models/lf10}\nstd::shared_ptr<int> p; // shared library\n')
        clean = scan(d, ['good.txt'])
    lines = sorted({int(p.split(':')[1]) for p in found})
    if lines != list(range(1, len(bad) + 1)) or clean:
        print(f'check_paths: self-test FAILED: flagged lines {lines} of 1..{len(bad)} '
              f'(and {len(clean)} in the clean file)', file=sys.stderr)
        return 1
    print(f'check_paths: self-test passed ({len(bad)} spellings caught, clean file passes)')
    return 0


def scan(root, files):
    """FILE:LINE: RULE: TEXT for every line of `files` (relative to root) that leaves the tree."""
    problems = []
    for rel in files:
        if rel == SELF:
            continue
        try:
            with open(os.path.join(root, rel), 'rb') as f:
                data = f.read()
        except OSError:
            continue  # listed by git but deleted in the work tree
        if b'\0' in data[:8192]:
            continue  # binary (the gzip'ed models, images)
        for number, line in enumerate(data.decode('utf-8', 'replace').splitlines(), 1):
            for pattern, rule in PATTERNS:
                if pattern.search(line):
                    problems.append(f'{rel}:{number}: {rule}: {line.strip()[:120]}')
                    break
    return problems


def main():
    if sys.argv[1:] == ['--self-test']:
        return self_test()
    root = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else ROOT
    files = tracked_files(root)
    problems = scan(root, files)
    for p in problems:
        print(p)
    if problems:
        print(f'check_paths: {len(problems)} reference(s) to outside the repository '
              f'(the project must carry what it needs: models/, tests/)', file=sys.stderr)
        return 1
    print(f'check_paths: {len(files)} tracked files, none refers to outside the repository')
    return 0


if __name__ == '__main__':
    sys.exit(main())
