#!/usr/bin/env python3
"""Shows that scripts/check_function_length.py can fail: it runs the script on small trees made
here and expects exit 1 for a function one line over the limit and exit 0 at the limit, whatever
sits around the function (namespaces, classes, lambdas, braces in strings and comments), and it
checks the long-function marker. Run: python3 tests/scripts/test_check_function_length.py
"""
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts',
                      'check_function_length.py')


def body(lines, indent='  '):
    """`lines` statements, one a line."""
    return ''.join(f'{indent}x += {i};\n' for i in range(lines))


def function(name, length, indent='', inner=''):
    """A function whose braces span `length` lines (the limit counts both brace lines); `inner`
    (whole lines) goes first in its body."""
    inner_lines = inner.count('\n')
    return (f'{indent}int {name}(int x) {{\n{inner}' + body(length - 2 - inner_lines, indent + '  ')
            + f'{indent}}}\n')


class CheckFunctionLength(unittest.TestCase):
    def run_on(self, files):
        """Runs the script on a tree of `files` (path -> text): (exit code, output)."""
        with tempfile.TemporaryDirectory() as root:
            for path, text in files.items():
                full = os.path.join(root, path)
                os.makedirs(os.path.dirname(full), exist_ok=True)
                with open(full, 'w', encoding='utf-8') as fh:
                    fh.write(text)
            done = subprocess.run([sys.executable, SCRIPT, root], capture_output=True, text=True)
            return done.returncode, done.stdout + done.stderr

    def assert_fails_naming(self, files, name, length):
        code, out = self.run_on(files)
        self.assertEqual(code, 1, out)
        self.assertIn(f'{name} is {length} lines (limit 120)', out)

    def assert_passes(self, files):
        code, out = self.run_on(files)
        self.assertEqual(code, 0, out)

    def test_limit_is_120_lines(self):
        self.assert_passes({'core/src/a.cpp': function('at_limit', 120)})
        self.assert_fails_naming({'core/src/a.cpp': function('over', 121)}, 'over', 121)

    def test_every_product_folder_is_checked(self):
        for folder in ('core/include/ecmor', 'strategies/src', 'plugins/krylov', 'apps/ecmor',
                       'python/src', 'run/src', 'interop/src'):
            with self.subTest(folder=folder):
                self.assert_fails_naming({f'{folder}/a.hpp': function('over', 121)}, 'over', 121)

    def test_tests_are_not_product(self):
        self.assert_passes({'tests/core/a.cpp': function('long_test', 300)})

    def test_namespaces_and_classes(self):
        text = ('namespace ecmor {\nnamespace {\nstruct Small {\n  int a = 1;\n};\n'
                '}  // namespace\n'
                'class ECMOR_API Reducer final : public Base {\n public:\n'
                + function('member', 121, indent='  ') + '  int m_x{3};\n};\n'
                + 'enum class Side { Right, Left };\n'
                + 'const Table kTable{\n' + body(200) + '};\n'
                + function('Reducer::out_of_class', 120) + '}  // namespace ecmor\n')
        self.assert_fails_naming({'core/src/a.cpp': text}, 'member', 121)
        code, out = self.run_on({'core/src/a.cpp': text})
        self.assertNotIn('kTable', out)
        self.assertNotIn('out_of_class', out)

    def test_constructor_with_braced_initialisers(self):
        text = ('Reducer::Reducer(int a, std::vector<int> v = {})\n    : m_a{a}, m_b(a), m_c{} {\n'
                + body(119) + '}\n')
        self.assert_fails_naming({'core/src/a.cpp': text}, 'Reducer::Reducer', 121)

    def test_lambdas_count_toward_the_enclosing_function(self):
        lam = '  auto f = [&](int y) {\n' + body(30, '    ') + '  };\n'
        outer = function('outer', 121, inner=lam)
        self.assert_fails_naming({'core/src/a.cpp': outer}, 'outer', 121)
        code, out = self.run_on({'core/src/a.cpp': function('outer', 120, inner=lam)})
        self.assertEqual(code, 0, out)
        # A lambda at namespace scope is a function of its own.
        text = 'const auto table = [] {\n' + body(119) + '}();\n'
        self.assert_fails_naming({'core/src/a.cpp': text}, 'table (lambda)', 121)

    def test_braces_in_strings_comments_and_literals_count_for_nothing(self):
        noise = ('  const char* s = "{ \\" {";\n  char c = \'{\';\n  // {\n  /* } {\n  */\n'
                 '  auto r = R"x(}{ " )x";\n  int big = 1\'000\'000;\n#define OPEN {\n')
        first = function('noisy', 10, inner=noise)
        self.assert_fails_naming({'core/src/a.cpp': first + function('after', 121)}, 'after', 121)
        self.assert_passes({'core/src/a.cpp': first + function('after', 120)})

    def test_marker_with_a_reason_allows_a_long_function(self):
        marked = ('// SLEPc\'s calling sequence.\n'
                  '// long-function: the SLEPc calling sequence must run as one\n'
                  + function('sequence', 150))
        code, out = self.run_on({'core/src/a.cpp': marked})
        self.assertEqual(code, 0, out)
        self.assertIn('sequence is 150 lines (allowed: the SLEPc calling sequence', out)
        inside = function('sequence', 150, inner='  // long-function: an ARPACK reverse loop\n')
        self.assert_passes({'core/src/a.cpp': inside})

    def test_marker_without_reason_or_without_need_fails(self):
        code, out = self.run_on({'core/src/a.cpp': '// long-function:\n' + function('f', 150)})
        self.assertEqual(code, 1, out)
        self.assertIn('gives no reason', out)
        code, out = self.run_on(
            {'core/src/a.cpp': '// long-function: it used to be long\n' + function('f', 20)})
        self.assertEqual(code, 1, out)
        self.assertIn('remove its long-function marker', out)
        code, out = self.run_on({'core/src/a.cpp': '// long-function: nothing follows it\n'})
        self.assertEqual(code, 1, out)
        self.assertIn('on no function', out)

    def test_an_unnamed_top_level_folder_fails(self):
        code, out = self.run_on({'newlib/CMakeLists.txt': '', 'newlib/a.cpp': function('f', 10)})
        self.assertEqual(code, 1, out)
        self.assertIn('newlib/', out)


if __name__ == '__main__':
    unittest.main()
