#!/usr/bin/python3
"""scripts/check-layers, scripts/layer-graph and scripts/bus-graph can fail: each case builds a
small fixture tree and target graph (the shape build/cobridge-targets.json
has) in a temporary directory and runs the real script on it.

  layers_selftest.py --scripts <source>/scripts
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import unittest

SCRIPTS = None


def write(root, rel, text):
    path = os.path.join(root, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'w', encoding='utf-8') as f:
        f.write(textwrap.dedent(text))
    return path


def target(root, folder, sources, links=(), interface_links=(), includes=()):
    return {'type': 'STATIC_LIBRARY', 'source_dir': os.path.join(root, folder), 'sources': list(sources),
            'links': list(links), 'interface_links': list(interface_links), 'includes': list(includes)}


class Fixture:
    """can <- canopen (PUBLIC) <- device (PUBLIC); sys linked PRIVATE by can."""

    def __init__(self, root):
        self.root = root
        write(root, 'daemon/sys/log.hpp', '#pragma once\n')
        write(root, 'daemon/sys/log.cpp', '#include "sys/log.hpp"\n')
        write(root, 'daemon/can/frame.hpp', '#pragma once\n')
        write(root, 'daemon/can/frame.cpp', '#include "can/frame.hpp"\n#include "sys/log.hpp"\n')
        write(root, 'daemon/canopen/nmt.hpp', '#pragma once\n#include "can/frame.hpp"\n')
        write(root, 'daemon/canopen/nmt.cpp', '#include "canopen/nmt.hpp"\n')
        write(root, 'daemon/device/eds.cpp', '#include "canopen/nmt.hpp"\n#include "can/frame.hpp"\n')
        # A test folder named like a layer: not the layer (no daemon/device/sim.hpp).
        write(root, 'tests/sim/device/sim.cpp', '#include "device/sim.hpp"\n')
        self.graph = {
            'source_dir': root, 'binary_dir': os.path.join(root, 'build'),
            'layers': ['sys', 'can', 'canopen', 'device'],
            'targets': {
                'cobridge_sys': target(root, 'daemon/sys', ['log.cpp']),
                'cobridge_can': target(root, 'daemon/can', ['frame.cpp'], ['cobridge_sys'],
                                       ['$<LINK_ONLY:cobridge_sys>']),
                'cobridge_canopen': target(root, 'daemon/canopen', ['nmt.cpp'], ['cobridge_can'], ['cobridge_can']),
                'cobridge_device': target(root, 'daemon/device', ['eds.cpp'], ['cobridge_canopen'],
                                          ['cobridge_canopen']),
                'sim_device': target(root, 'tests/sim/device', ['sim.cpp'], ['cobridge_device']),
            }}

    def save(self):
        path = os.path.join(self.root, 'targets.json')
        with open(path, 'w', encoding='utf-8') as f:
            json.dump(self.graph, f)
        return path


def run(script, *args, cwd=None):
    return subprocess.run([sys.executable, os.path.join(SCRIPTS, script), *args], capture_output=True, text=True,
                          cwd=cwd)


class CheckLayers(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.fx = Fixture(self.tmp.name)

    def tearDown(self):
        self.tmp.cleanup()

    def check(self):
        return run('check-layers', '--graph', self.fx.save())

    def test_clean_tree_passes(self):
        r = self.check()
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_upward_include_fails_with_file_line_layer_and_links(self):
        write(self.fx.root, 'daemon/can/frame.cpp', '#include "can/frame.hpp"\n#include "canopen/nmt.hpp"\n')
        r = self.check()
        self.assertEqual(r.returncode, 1)
        self.assertIn('daemon/can/frame.cpp:2: includes "canopen/nmt.hpp" (layer canopen), '
                      'but target cobridge_can links can, sys', r.stderr)

    def test_violation_in_a_header_beside_the_sources_fails(self):
        write(self.fx.root, 'daemon/canopen/sdo.hpp', '#pragma once\n\n#include "device/eds.hpp"\n')
        write(self.fx.root, 'daemon/device/eds.hpp', '#pragma once\n')
        r = self.check()
        self.assertEqual(r.returncode, 1)
        self.assertIn('daemon/canopen/sdo.hpp:3: includes "device/eds.hpp" (layer device)', r.stderr)

    def test_private_link_does_not_reach_the_layers_above(self):
        # can links sys PRIVATE: canopen, which links can, must not see sys.
        write(self.fx.root, 'daemon/canopen/nmt.cpp', '#include "canopen/nmt.hpp"\n#include "sys/log.hpp"\n')
        r = self.check()
        self.assertEqual(r.returncode, 1)
        self.assertIn('daemon/canopen/nmt.cpp:2: includes "sys/log.hpp" (layer sys), '
                      'but target cobridge_canopen links can, canopen', r.stderr)

    def test_a_namespace_other_than_the_layers_fails(self):
        write(self.fx.root, 'daemon/canopen/nmt.hpp', '#pragma once\nnamespace cobridge::canopen::sdo {}\n'
              'namespace cobridge::gateway {\n}\n')
        r = self.check()
        self.assertEqual(r.returncode, 1)
        self.assertIn('daemon/canopen/nmt.hpp:3: namespace cobridge::gateway in layer canopen '
                      '(want cobridge::canopen)', r.stderr)
        self.assertNotIn('nmt.hpp:2', r.stderr)

    def test_daemon_folder_on_the_include_path_fails(self):
        self.fx.graph['targets']['cobridge_canopen']['includes'] = [os.path.join(self.fx.root, 'daemon')]
        r = self.check()
        self.assertEqual(r.returncode, 1)
        self.assertIn('cobridge_canopen: include directory', r.stderr)


class LayerGraph(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.fx = Fixture(self.tmp.name)
        self.doc = write(self.tmp.name, 'docs/architecture.md', """\
            # Layers
            <!-- layer-graph:begin (scripts/layer-graph --write) -->
            ```mermaid
            flowchart TD
              can --> sys
            ```
            <!-- layer-graph:end -->
            after
            """)

    def tearDown(self):
        self.tmp.cleanup()

    def graph(self, *mode):
        return run('layer-graph', '--graph', self.fx.save(), '--doc', self.doc, *mode)

    def test_stale_drawing_fails_and_write_repairs_it(self):
        r = self.graph('--check')
        self.assertEqual(r.returncode, 1)
        self.assertIn('+  canopen --> can', r.stderr)
        self.assertEqual(self.graph('--write').returncode, 0)
        r = self.graph('--check')
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(self.doc, encoding='utf-8') as f:
            text = f.read()
        self.assertIn('  device --> canopen\n', text)
        self.assertTrue(text.endswith('<!-- layer-graph:end -->\nafter\n'))

    def test_a_new_link_in_the_build_makes_the_drawing_stale(self):
        self.assertEqual(self.graph('--write').returncode, 0)
        self.fx.graph['targets']['cobridge_device']['links'].append('cobridge_sys')
        r = self.graph('--check')
        self.assertEqual(r.returncode, 1)
        self.assertIn('+  device --> sys', r.stderr)


class BusGraph(unittest.TestCase):
    """daemon/bus/ drawn from its includes: a new include makes the drawing stale."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.root = self.tmp.name
        write(self.root, 'daemon/bus/agent.hpp', '#pragma once\n')
        write(self.root, 'daemon/bus/agent.cpp', '#include "bus/agent.hpp"\n#include "canopen/sdo.hpp"\n')
        write(self.root, 'daemon/bus/manager_frames.cpp', '#include "bus/agent.hpp"\n')
        write(self.root, 'daemon/bus/discovery/probe.hpp', '#pragma once\n')
        self.doc = write(self.root, 'docs/architecture.md', """\
            <!-- bus-graph:begin (scripts/bus-graph --write) -->
            <!-- bus-graph:end -->
            after
            """)

    def tearDown(self):
        self.tmp.cleanup()

    def graph(self, *mode):
        return run('bus-graph', '--doc', self.doc, *mode, cwd=self.root)

    def test_write_draws_rooms_boxes_and_arrows_then_a_new_include_fails_the_check(self):
        self.assertEqual(self.graph('--check').returncode, 1)
        self.assertEqual(self.graph('--write').returncode, 0)
        self.assertEqual(self.graph('--check').returncode, 0)
        with open(self.doc, encoding='utf-8') as f:
            text = f.read()
        self.assertIn('  manager_frames --> agent\n', text)
        self.assertIn('subgraph dir_discovery["bus/discovery/"]', text)
        self.assertNotIn('canopen', text)  # the layers below are the layer graph's
        self.assertTrue(text.endswith('<!-- bus-graph:end -->\nafter\n'))
        write(self.root, 'daemon/bus/agent.cpp', '#include "bus/agent.hpp"\n#include "bus/discovery/probe.hpp"\n')
        r = self.graph('--check')
        self.assertEqual(r.returncode, 1)
        self.assertIn('+  agent --> discovery__probe', r.stderr)


if __name__ == '__main__':
    ap = argparse.ArgumentParser()
    ap.add_argument('--scripts', required=True)
    args, rest = ap.parse_known_args()
    SCRIPTS = os.path.abspath(args.scripts)
    unittest.main(argv=[sys.argv[0], *rest], verbosity=2)
