#!/usr/bin/env python3
"""Checks that no product function is longer than 120 lines (issue 49, section 5: functions that
read in one sitting). Prints every longer one as FILE:LINE: NAME is N lines and exits 1 if there
is one.

What counts. The C++ sources (.cpp, .hpp, .h, .cc) under the product folders PRODUCT_FOLDERS
(absent ones are skipped). A function's length runs from the line of its opening brace to the
line of its closing brace, both counted. Free functions, member functions (in a class body or out
of it), constructors and lambdas at namespace scope are functions; a lambda, a local class or a
block inside a function counts toward the enclosing function. Namespaces, classes, enums and
brace initialisers of variables (tables of options) are not functions. Comments, string and
character literals (raw strings too) and preprocessor lines are blanked before the braces are
counted, so a brace inside them counts for nothing.

The allow-list. A function may be longer when it says why, with a marker in the comment block
right above it or in the first lines of its body:
    // long-function: <the reason, in words>
A marker without a reason is an error, and so is a marker on a function within the limit or on
no function (it would outlive its reason). Keep the reason to what cannot be split (an ARPACK
reverse-communication loop, a SLEPc calling sequence).

A top-level folder with a CMakeLists.txt that is in neither PRODUCT_FOLDERS nor OTHER_FOLDERS is
reported too: a new product folder must be named here to be checked.

Run from anywhere: python3 scripts/check_function_length.py [--limit N] [ROOT]
(default: this script's repository, 120 lines)
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LIMIT = 120
# The product: what ships. New top-level product folders are added here (run/ and interop/ are
# planned by issue 49).
PRODUCT_FOLDERS = ['core', 'strategies', 'plugins', 'apps', 'python/src', 'run', 'interop']
# Top-level folders that are not product code (tests, benchmarks, fuzz targets, examples, ...).
OTHER_FOLDERS = ['tests', 'bench', 'fuzz', 'examples', 'docs', 'configs', 'models', 'scripts',
                 'cmake', 'python', '.ci', '.git']
EXTENSIONS = ('.cpp', '.hpp', '.h', '.cc')
MARKER = re.compile(r'long-function:(.*)')
# Lines above a function, or into its body, in which its marker is looked for.
MARKER_BODY_LINES = 3


def blank_code(text):
    """The text with comments, string and character literals and preprocessor lines replaced by
    spaces (newlines kept, so line numbers stay), and the comments' text by line number."""
    out = list(text)
    comments = {}  # line -> comment text on it
    i, n, line = 0, len(text), 1
    at_line_start = True

    def blank(a, b):
        for k in range(a, b):
            if out[k] != '\n':
                out[k] = ' '

    def note_comment(a, b, first_line):
        ln = first_line
        for part in text[a:b].split('\n'):
            comments[ln] = comments.get(ln, '') + part
            ln += 1

    while i < n:
        c = text[i]
        if c == '\n':
            line += 1
            at_line_start = True
            i += 1
            continue
        if at_line_start and c == '#':
            # A preprocessor line, with its backslash continuations.
            j = i
            while j < n:
                if text[j] == '\n' and text[j - 1] != '\\':
                    break
                j += 1
            line += text.count('\n', i, j)
            blank(i, j)
            i = j
            continue
        if not c.isspace():
            at_line_start = False
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            note_comment(i, j, line)
            blank(i, j)
            i = j
            continue
        if text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            note_comment(i, j, line)
            line += text.count('\n', i, j)
            blank(i, j)
            i = j
            continue
        raw = re.match(r'(?:u8|[uUL])?R"([^()\\\s]{0,16})\(', text[i:i + 24])
        if raw and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == '_')):
            end = text.find(')' + raw.group(1) + '"', i + raw.end())
            j = n if end < 0 else end + len(raw.group(1)) + 2
            line += text.count('\n', i, j)
            blank(i, j)
            i = j
            continue
        if c == '"' or (c == "'" and not digit_separator(text, i)):
            j = i + 1
            while j < n and text[j] != c and text[j] != '\n':
                j += 2 if text[j] == '\\' else 1
            j = min(j + 1, n)
            blank(i, j)
            i = j
            continue
        i += 1
    return ''.join(out), comments


def digit_separator(text, i):
    """True when the quote at i separates digits of a number (1'000'000), not a character."""
    j = i
    while j > 0 and (text[j - 1].isalnum() or text[j - 1] in "'."):
        j -= 1
    return j < i and text[j].isdigit()


def paren_depth(text):
    """How many ( and [ of the text are still open at its end."""
    depth = 0
    for c in text:
        if c in '([':
            depth += 1
        elif c in ')]':
            depth = max(0, depth - 1)
    return depth


def top_level(header):
    """The header with the contents of every (...) and [...] group removed, the brackets kept,
    for keyword tests: `void f(int a = 1)` becomes `void f()`."""
    out, depth = [], 0
    for c in header:
        if c in ')]':
            depth = max(0, depth - 1)
        if depth == 0:
            out.append(c)
        if c in '([':
            depth += 1
    return ''.join(out)


def without_templates(header):
    """The header without template <...> parameter lists (their `class T` is no class)."""
    return re.sub(r'\btemplate\s*<[^<>]*(?:<[^<>]*>[^<>]*)*>', ' ', header)


LAMBDA_END = re.compile(r'\]\s*(\([^()]*(\([^()]*\)[^()]*)*\))?\s*'
                        r'(mutable|constexpr|noexcept|->\s*[\w:<>,\s*&]+)*\s*$')
CTOR_INIT = re.compile(r'\)\s*(noexcept\s*)?:(?!:)')


def function_name(header):
    """The name of the function a header declares: the identifier before its parameter list (the
    last top-level one before a constructor's initialisers)."""
    h = re.sub(r'\s+', ' ', header).strip()
    init = CTOR_INIT.search(h)
    if init:
        h = h[:init.start() + 1]
    m = re.search(r'((?:[A-Za-z_]\w*\s*::\s*)*)\boperator\s*(\(\)|\[\]|[^\s(]+)\s*\(', h)
    if m:
        return m.group(1).replace(' ', '') + 'operator' + m.group(2)
    best = None
    for m in re.finditer(r'(~?[A-Za-z_]\w*(?:\s*::\s*~?[A-Za-z_]\w*)*)\s*\(', h):
        if paren_depth(h[:m.start()]) == 0:
            best = m.group(1).replace(' ', '')
    if best is None or re.search(r'\]\s*(\(|$)', top_level(h)[-40:]):
        # A lambda: named by the variable it initialises, if any.
        v = re.search(r'([A-Za-z_]\w*)\s*=\s*\[', h)
        return (v.group(1) if v else 'lambda') + ' (lambda)'
    return best


def classify(header):
    """What a brace opened at namespace or class scope opens: 'scope' (namespace, extern "C",
    class body), 'function', 'ctor-init' (a member initialiser inside a constructor's list) or
    'other' (enum, brace initialiser, a braced default argument)."""
    h = re.sub(r'\s+', ' ', header).strip()
    if paren_depth(h) > 0:
        return 'other'  # inside a parameter list: a braced default argument
    plain = top_level(without_templates(h))
    if re.search(r'\bnamespace\b', plain) or re.fullmatch(r'extern', h):
        return 'scope'  # (extern "C": the string is blanked)
    if re.search(r'\benum\b', plain):
        return 'other'
    if re.search(r'\b(class|struct|union)\b', plain) and '(' not in plain and '=' not in plain:
        return 'scope'
    if '[' in h and LAMBDA_END.search(h):
        return 'function'
    if re.search(r'\boperator\b', h):
        return 'function'
    if '=' in plain.replace('==', ''):
        return 'other'
    if CTOR_INIT.search(h):
        # A constructor: its body follows the ")" or "}" of the last initialiser; a brace after a
        # member's name is that member's initialiser.
        return 'function' if re.search(r'[)}]\s*(noexcept\s*)?$', h) else 'ctor-init'
    if '(' in plain:
        return 'function'
    return 'other'


def functions(text):
    """(name, first header line, opening brace line, closing brace line) of each function."""
    code, comments = blank_code(text)
    found = []
    # Stack of what each open brace is: ('scope'|'function'|'other'|'ctor-init', ...).
    stack = []
    header, header_line = [], None
    line = 1
    depth_in_function = 0  # braces open inside the current function (0: none open)
    current = None
    for c in code:
        if c == '\n':
            line += 1
            if depth_in_function == 0:
                header.append(' ')
            continue
        if depth_in_function > 0:
            if c == '{':
                depth_in_function += 1
            elif c == '}':
                depth_in_function -= 1
                if depth_in_function == 0:
                    found.append((current[0], current[1], current[2], line))
                    current = None
            continue
        if stack and stack[-1] == 'other':
            if c == '{':
                stack.append('other')
            elif c == '}':
                stack.pop()
            continue
        if c == '{':
            text_so_far = ''.join(header)
            kind = classify(text_so_far)
            if kind == 'function':
                depth_in_function = 1
                current = (function_name(text_so_far), header_line or line, line)
                header, header_line = [], None
            elif kind == 'ctor-init':
                stack.append('other')  # the member's initialiser; the header goes on
                header.append('{}')
            elif kind == 'scope':
                stack.append('scope')
                header, header_line = [], None
            else:
                stack.append('other')
                header.append('{}')
            continue
        if c == '}':
            if stack:
                stack.pop()
            header, header_line = [], None
            continue
        if c == ';':
            header, header_line = [], None
            continue
        if c == ':' and re.search(r'\b(public|private|protected)\s*$', ''.join(header)):
            header, header_line = [], None
            continue
        if not c.isspace() and header_line is None:
            header_line = line
        header.append(c)
    return found, comments


def marker_of(comments, header_line, open_line):
    """(line, reason) of the marker attached to a function: in the comment lines directly above
    its header, or in the first MARKER_BODY_LINES lines of its body; None without one."""
    ln = header_line - 1
    while ln in comments:
        m = MARKER.search(comments[ln])
        if m:
            return ln, m.group(1).strip()
        ln -= 1
    for ln in range(open_line, open_line + MARKER_BODY_LINES + 1):
        m = MARKER.search(comments.get(ln, ''))
        if m:
            return ln, m.group(1).strip()
    return None


def check_file(path, rel, limit):
    with open(path, encoding='utf-8', errors='replace') as fh:
        text = fh.read()
    found, comments = functions(text)
    problems, allowed = [], []
    used_markers = set()
    for name, header_line, open_line, close_line in found:
        length = close_line - open_line + 1
        marker = marker_of(comments, header_line, open_line)
        if marker:
            used_markers.add(marker[0])
        where = f'{rel}:{header_line}: {name}'
        if marker and len(re.sub(r'\W', '', marker[1])) < 10:
            problems.append(f'{where}: its long-function marker gives no reason')
        elif length > limit and marker:
            allowed.append(f'{where} is {length} lines (allowed: {marker[1]})')
        elif length > limit:
            problems.append(f'{where} is {length} lines (limit {limit}): split it, or say why '
                            f'it cannot be split with "// long-function: <reason>"')
        elif marker:
            problems.append(f'{where} is {length} lines, within the limit {limit}: remove its '
                            f'long-function marker')
    for ln, comment in sorted(comments.items()):
        if MARKER.search(comment) and ln not in used_markers:
            problems.append(f'{rel}:{ln}: a long-function marker on no function (it belongs in '
                            f'the comment right above one, or in its first lines)')
    return problems, allowed


def unclassified_folders(root):
    named = {f.split('/')[0] for f in PRODUCT_FOLDERS} | set(OTHER_FOLDERS)
    out = []
    for entry in sorted(os.listdir(root)):
        full = os.path.join(root, entry)
        if (os.path.isdir(full) and entry not in named and
                os.path.isfile(os.path.join(full, 'CMakeLists.txt'))):
            out.append(f'{entry}/: a top-level folder with a CMakeLists.txt that '
                       f'scripts/check_function_length.py does not name (add it to '
                       f'PRODUCT_FOLDERS or OTHER_FOLDERS)')
    return out


def check(root, limit=LIMIT):
    problems, allowed = unclassified_folders(root), []
    for folder in PRODUCT_FOLDERS:
        top = os.path.join(root, folder)
        for dirpath, subdirs, files in os.walk(top):
            subdirs.sort()
            for f in sorted(files):
                if not f.endswith(EXTENSIONS):
                    continue
                full = os.path.join(dirpath, f)
                p, a = check_file(full, os.path.relpath(full, root), limit)
                problems += p
                allowed += a
    return problems, allowed


def main(argv):
    limit, root = LIMIT, ROOT
    args = list(argv)
    while args:
        a = args.pop(0)
        if a == '--limit' and args:
            limit = int(args.pop(0))
        elif a in ('-h', '--help'):
            print(__doc__)
            return 0
        else:
            root = a
    problems, allowed = check(root, limit)
    for a in allowed:
        print(a)
    for p in problems:
        print(p)
    if problems:
        print(f'check_function_length: {len(problems)} problem(s); functions longer than {limit} '
              f'lines read in more than one sitting (issue 49)')
        return 1
    print(f'check_function_length: every product function is at most {limit} lines'
          + (f' ({len(allowed)} allowed by a long-function marker)' if allowed else ''))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
