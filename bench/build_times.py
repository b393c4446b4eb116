#!/usr/bin/env python3
"""Where a build's time went, from ninja's log: seconds per part of the tree (core, plugins,
strategies, apps, each tests/ folder, bench), compile against link, and the slowest files.

Usage: python3 bench/build_times.py [BUILD_DIR] [--top N] [--markdown]
  BUILD_DIR  a ninja build directory after a build from scratch (default build); its .ninja_log
             holds the start and end of every step of the last build of each output.
Each step's seconds are its wall time as ninja saw it; with `-j 2` on two cores two steps run at
once, so the sum over steps is about twice the build's wall time (it is the CPU the build needs).
Compare two builds made the same way (same -j, same machine, nothing else running).
"""
import collections
import os
import sys


def part_of(output):
    """The part of the tree a build output belongs to."""
    path = output.replace('\\', '/')
    if '/CMakeFiles/' in path:
        path = path.split('/CMakeFiles/')[0]
    top = path.split('/')[0]
    if top == 'tests' and '/' in path:
        return 'tests/' + path.split('/')[1]
    if top in ('bin', 'lib', ''):
        return 'executables and libraries'
    return top


def main():
    args = sys.argv[1:]
    top = 15
    markdown = '--markdown' in args
    if '--top' in args:
        top = int(args[args.index('--top') + 1])
        del args[args.index('--top'):args.index('--top') + 2]
    args = [a for a in args if a != '--markdown']
    build = args[0] if args else 'build'
    log = os.path.join(build, '.ninja_log')
    if not os.path.exists(log):
        sys.exit(f'build_times: {log} not found (a ninja build directory is needed)')
    steps = {}
    with open(log) as f:
        for line in f:
            if line.startswith('#'):
                continue
            fields = line.rstrip('\n').split('\t')
            if len(fields) < 4:
                continue
            start, end, output = int(fields[0]), int(fields[1]), fields[3]
            steps[output] = (start, end)  # the last build of each output counts
    if not steps:
        sys.exit(f'build_times: {log} holds no steps')
    per_part = collections.defaultdict(lambda: [0.0, 0, 0.0, 0])  # compile s, files, link s, links
    files = []
    for output, (start, end) in steps.items():
        seconds = (end - start) / 1000.0
        entry = per_part[part_of(output)]
        if output.endswith('.o'):
            entry[0] += seconds
            entry[1] += 1
            files.append((seconds, output.split('/CMakeFiles/')[0] + '/' +
                          os.path.basename(output)[:-2]))
        else:
            entry[2] += seconds
            entry[3] += 1
    wall = (max(e for _, e in steps.values()) - min(s for s, _ in steps.values())) / 1000.0
    compile_total = sum(v[0] for v in per_part.values())
    link_total = sum(v[2] for v in per_part.values())
    sep = ' | ' if markdown else '  '
    print(f'build wall time {wall:.0f} s; step seconds {compile_total + link_total:.0f} '
          f'(compile {compile_total:.0f}, link and other steps {link_total:.0f}) in {len(steps)} steps')
    if markdown:
        print('\n| part | compile s | files | link and other s | steps |\n|---|---|---|---|---|')
    for part, (c, n, l, k) in sorted(per_part.items(), key=lambda kv: -(kv[1][0] + kv[1][2])):
        row = [part, f'{c:.0f}', str(n), f'{l:.0f}', str(k)]
        print(('| ' + sep.join(row) + ' |') if markdown else sep.join(f'{x:>10}' for x in row))
    print(f'\nslowest {top} files:')
    for seconds, name in sorted(files, reverse=True)[:top]:
        print(f'  {seconds:6.1f} s  {name}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
