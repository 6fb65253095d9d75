"""The package as a whole: its type stubs describe the extension that is built."""

import ast
import inspect
import os
import unittest

import colony
from colony import _native


class Stubs(unittest.TestCase):
    def test_the_stubs_name_every_class_and_method_of_the_extension_and_no_other(self):
        path = os.path.join(os.path.dirname(colony.__file__), "_native.pyi")
        with open(path) as f:
            tree = ast.parse(f.read())
        stubbed = {
            node.name: {n.name for n in node.body if isinstance(n, ast.FunctionDef)} - {"__init__"}
            for node in tree.body
            if isinstance(node, ast.ClassDef)
        }
        built = {
            name: {m for m in dir(cls) if not m.startswith("_")}
            for name, cls in inspect.getmembers(_native, inspect.isclass)
        }
        self.assertEqual(set(stubbed), set(built))
        for name in built:
            self.assertEqual(stubbed[name], built[name], name)


class Publisher(unittest.TestCase):
    def test_a_malformed_packet_is_refused_saying_where(self):
        # Nothing listens on port 9: datagrams are fire and forget.
        publisher = _native.Publisher("127.0.0.1:9")
        publisher.publish([b"@ <vision> 0\nstep n 1\n"])
        self.assertEqual(publisher.sent, 1)
        with self.assertRaisesRegex(ValueError, "malformed packet: .*line"):
            publisher.publish([b"@ <vision> 0\nstep n 1\n\x00\n"])
        with self.assertRaises(OSError):
            _native.Publisher("no.such.host.invalid:7400")


if __name__ == "__main__":
    unittest.main()
