"""Request and reply: the sans-IO Caller and Provider on their own, then
through the real Rust hub against `colony serve` and `colony call`.

Standard library only; run with the rest: python3 -m unittest discover -s python/tests -v
"""

import os
import subprocess
import sys
import time
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(0, HERE)

import colony_client as cc  # noqa: E402
from test_client import _HubCase, _child_env, _die_with_parent, colony_bin, run_colony  # noqa: E402

LEASE = 3.0


class Net:
    """Delivers what each side publishes to the sides subscribed to its
    subject, as a hub would, until nothing more is sent."""

    def __init__(self, providers, now):
        self.caller = cc.Caller("echo", "0000000000000007")
        self.providers = [
            cc.Provider("echo", now, LEASE, "%016x" % (100 + i)) for i in range(providers)
        ]
        self.dead = [False] * providers
        self.taken = [[] for _ in range(providers)]

    def run(self, now):
        while True:
            sent = []
            d = self.caller.poll_transmit()
            while d is not None:
                sent.append(d)
                d = self.caller.poll_transmit()
            for i, p in enumerate(self.providers):
                d = p.poll_transmit()
                while d is not None:
                    if not self.dead[i]:
                        sent.append(d)
                    d = p.poll_transmit()
            if not sent:
                return
            for data in sent:
                packet = cc.parse(data)
                if set(packet.subjects) & set(self.caller.subjects()):
                    self.caller.handle_packet(now, packet)
                for i, p in enumerate(self.providers):
                    if self.dead[i] or not set(packet.subjects) & set(p.subjects()):
                        continue
                    call = p.handle_packet(now, packet)
                    if call is None:
                        continue
                    self.taken[i].append(call.id)
                    if call.lines and call.lines[0].startswith("fail"):
                        p.refuse(call, "asked to fail")
                    else:
                        p.answer(call, call.lines)

    def outcomes(self):
        got = []
        o = self.caller.poll_outcome()
        while o is not None:
            got.append(o)
            o = self.caller.poll_outcome()
        return got


class SansIO(unittest.TestCase):
    def test_calls_are_spread_over_the_providers_and_each_is_answered_once(self):
        net = Net(2, 0.0)
        net.run(0.0)
        self.assertEqual(len(net.caller.providers()), 2)
        ids = [net.caller.call(0.0, ["n value %d" % i]) for i in range(10)]
        net.run(0.0)
        outcomes = net.outcomes()
        self.assertEqual(sorted(i for i, _ in outcomes), sorted(ids))
        for call_id, answer in outcomes:
            self.assertIsInstance(answer, cc.Answer)
            self.assertEqual(answer.lines, ["n value %d" % ids.index(call_id)])
        self.assertEqual([len(t) for t in net.taken], [5, 5])
        self.assertEqual(net.caller.in_flight, 0)

    def test_a_silent_provider_ends_its_calls_at_its_lease(self):
        net = Net(2, 0.0)
        net.run(0.0)
        net.dead[0] = True
        for _ in range(4):
            net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        self.assertEqual(len(net.outcomes()), 2)
        now = 0.0
        while now < LEASE:
            now += 0.1
            net.caller.handle_timeout(now)
            net.providers[1].handle_timeout(now)
            net.run(now)
        ended = net.outcomes()
        self.assertEqual([e.kind for _, e in ended], ["provider_lapsed"] * 2)
        self.assertTrue(all(e.provider == "%016x" % 100 for _, e in ended))
        self.assertEqual(net.caller.providers(), ["%016x" % 101])

    def test_no_provider_refusal_and_leaving_end_calls_with_their_reason(self):
        caller = cc.Caller("nobody")
        caller.call(0.0, ["x y 1"], timeout=1.0)
        caller.handle_timeout(1.0)
        (_, err), = [caller.poll_outcome()]
        self.assertEqual(err.kind, "no_provider")
        self.assertIn("no provider", str(err))

        net = Net(1, 0.0)
        net.run(0.0)
        net.caller.call(0.0, ["fail why now"])
        net.run(0.0)
        (_, err), = net.outcomes()
        self.assertEqual((err.kind, str(err).endswith("asked to fail")), ("refused", True))

        # A provider that says it is leaving gets no new calls, and the ones
        # it holds end with its lease, not at once: anyone could forge `leaving`.
        net.dead[0] = True
        net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        net.dead[0] = False
        net.providers[0].leave()
        net.run(0.0)
        self.assertEqual(net.outcomes(), [])
        self.assertEqual(net.caller.providers(), [])
        net.caller.handle_timeout(LEASE)
        (_, err), = net.outcomes()
        self.assertEqual(err.kind, "provider_left")

    def test_forged_and_repeated_answers_are_strays(self):
        net = Net(1, 0.0)
        net.run(0.0)
        call_id = net.caller.call(0.0, ["x y 1"])
        forged = "@ <%s> 0\nreply id %s from %016x\n" % (net.caller.inbox, call_id, 666)
        net.caller.handle_packet(0.0, cc.parse(forged.encode()))
        self.assertEqual(net.caller.in_flight, 1)
        net.run(0.0)
        self.assertEqual(len(net.outcomes()), 1)
        answer = "@ <%s> 0\nreply id %s from %016x\n" % (net.caller.inbox, call_id, 100)
        net.caller.handle_packet(0.0, cc.parse(answer.encode()))
        self.assertEqual(net.outcomes(), [])
        self.assertEqual(net.caller.strays, 2)

    def test_a_provider_answers_only_reply_inboxes_and_who_at_most_every_100_ms(self):
        p = cc.Provider("echo", 0.0, LEASE, "%016x" % 100)
        while p.poll_transmit() is not None:
            pass
        aimed = "@ <%s> 0\ncall id 0000000000000001 reply_to radio\ncmd id 1\n" % p.inbox
        self.assertIsNone(p.handle_packet(0.0, cc.parse(aimed.encode())))
        who = cc.parse(b"@ <svc.echo> 0\nwho\n")
        announced = 0
        for ms in range(1, 2001):
            p.handle_packet(ms / 1000.0, who)
            while p.poll_transmit() is not None:
                announced += 1
        # At most once per third of its 3 s lease.
        self.assertEqual(announced, 2)

    def test_forged_notices_neither_crash_nor_cut_a_providers_lease_nor_fill_memory(self):
        net = Net(1, 0.0)
        net.run(0.0)
        # `leaving` for an id nobody knows.
        net.caller.handle_packet(0.0, cc.parse(b"@ <svc.echo> 0\nleaving id 0123456789abcdef\n"))
        net.dead[0] = True
        net.caller.call(0.0, ["x y 1"], timeout=60.0)
        net.run(0.0)
        forged = "@ <svc.echo> 0\nprovider id %016x lease_ms 0\n" % 100
        net.caller.handle_packet(0.0, cc.parse(forged.encode()))
        net.caller.handle_timeout(1.0)
        self.assertEqual(net.outcomes(), [])
        for i in range(2000):
            p = "@ <svc.echo> 0\nprovider id %016x lease_ms 3600000\n" % (1000 + i)
            net.caller.handle_packet(0.0, cc.parse(p.encode()))
        self.assertEqual(len(net.caller.providers()), 64)
        net.caller.handle_timeout(61.0)
        self.assertEqual(net.caller.providers(), [])

    def test_ids_are_bare_and_a_reason_is_no_group(self):
        caller = cc.Caller("echo", "0000000000000007")
        caller.handle_packet(0.0, cc.parse(b'@ <svc.echo> 0\nprovider id "00000000000000aa" lease_ms 3000\n'))
        self.assertEqual(caller.providers(), [])
        caller.handle_packet(0.0, cc.parse(b"@ <svc.echo> 0\nprovider id 00000000000000aa lease_ms 3000\n"))
        for text, want in [("007", "007"), ("1e5", "1e5"), ('"disk \\"full\\""', 'disk "full"'), ("(a 1)", None)]:
            call_id = caller.call(0.0, ["x y 1"])
            d = caller.poll_transmit()
            while d is not None:
                d = caller.poll_transmit()
            answer = "@ <reply.0000000000000007> 0\nrefused id %s from 00000000000000aa text %s\n" % (call_id, text)
            caller.handle_packet(0.0, cc.parse(answer.encode()))
            got = caller.poll_outcome()
            if want is None:
                self.assertIsNone(got)
            else:
                self.assertTrue(str(got[1]).endswith(": " + want), str(got[1]))

    def test_bad_names_and_lines_are_refused_at_once(self):
        for bad in ["a b", "x" * (cc.MAX_SERVICE_LEN + 1), "", 5, "a.0123456789abcdef"]:
            with self.assertRaises(ValueError):
                cc.Caller(bad)
        cc.Caller("x" * cc.MAX_SERVICE_LEN)
        cc.Caller("a.v2")
        with self.assertRaises(ValueError):
            cc.Caller("echo").call(0.0, ["x y 1"], timeout=0)
        caller = cc.Caller("echo")
        with self.assertRaises(cc.ParseError):
            caller.call(0.0, ["x ("])
        self.assertEqual(caller.in_flight, 0)

    def test_ids_that_look_like_numbers_stay_ids(self):
        # A provider id of decimal digits must not be read as an integer.
        net = Net(0, 0.0)
        p = cc.Provider("echo", 0.0, LEASE, "0000000000000123")
        net.providers.append(p)
        net.dead.append(False)
        net.taken.append([])
        net.run(0.0)
        self.assertEqual(net.caller.providers(), ["0000000000000123"])
        net.caller.call(0.0, ["x y 1"])
        net.run(0.0)
        (_, answer), = net.outcomes()
        self.assertEqual(answer.provider, "0000000000000123")


class ThroughTheRustHub(_HubCase):
    def serve(self, *args):
        path, _ = colony_bin()
        proc = subprocess.Popen(
            [path, "serve", "--hub", self.hub.addr_text] + list(args),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=_child_env(),
            preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None,
        )

        def stop():
            if proc.poll() is None:
                proc.kill()
            proc.wait(timeout=5.0)
            proc.stdout.close()

        self.addCleanup(stop)
        first = proc.stdout.readline().decode()
        self.assertTrue(first.startswith("provider "), first)
        return proc, first.split()[1]

    def test_python_calls_a_rust_provider_and_the_rust_cli_calls_a_python_one(self):
        self.serve("--echo", "echo")
        with cc.CallClient(self.hub.addr, "echo") as c:
            answer = c.call(['text value "hi there"', "n value 3"], timeout=10.0)
        self.assertEqual(answer.lines, ['text value "hi there"', "n value 3"])

        server = cc.ServeClient(self.hub.addr, "upper", lease=3.0)
        self.addCleanup(server.close)
        path, _ = colony_bin()
        call = subprocess.Popen(
            [path, "call", "--hub", self.hub.addr_text, "--timeout", "10", "upper", 'text value "abc"'],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=_child_env(),
        )
        deadline = time.monotonic() + 20.0
        while call.poll() is None and time.monotonic() < deadline:
            server.poll(lambda c: [l.upper() for l in c.lines])
            time.sleep(0.005)
        out, err = call.communicate(timeout=5.0)
        self.assertEqual(call.returncode, 0, err)
        self.assertEqual(out.decode(), 'TEXT VALUE "ABC"\n')

    def test_a_python_handler_that_raises_refuses_the_call_with_its_message(self):
        server = cc.ServeClient(self.hub.addr, "broken")
        self.addCleanup(server.close)
        with cc.CallClient(self.hub.addr, "broken") as c:
            call_id = c.start(["x y 1"], timeout=10.0)

            def handler(call):
                raise RuntimeError("no such thing")

            deadline = time.monotonic() + 20.0
            outcome = None
            while outcome is None and time.monotonic() < deadline:
                server.poll(handler)
                c.poll()
                outcome = c.poll_outcome()
                time.sleep(0.005)
        self.assertIsNotNone(outcome)
        self.assertEqual(outcome[0], call_id)
        self.assertEqual(outcome[1].kind, "refused")
        self.assertIn("RuntimeError: no such thing", str(outcome[1]))

    def test_calls_spread_over_two_providers_end_once_when_one_is_killed(self):
        slow = ["--lease", "5", "work", "--", "sh", "-c", "sleep 0.02; cat"]
        first, first_id = self.serve(*slow)
        self.serve(*slow)
        ended = {}
        with cc.CallClient(self.hub.addr, "work") as c:
            deadline = time.monotonic() + 20.0
            while len(c.caller.providers()) < 2 and time.monotonic() < deadline:
                c.poll()
                time.sleep(0.01)
            started = {}
            killed = False
            deadline = time.monotonic() + 120.0
            while len(ended) < 40 and time.monotonic() < deadline:
                while len(started) < 40 and c.caller.in_flight < 6:
                    n = len(started)
                    started[c.start(["n value %d" % n], timeout=60.0)] = n
                c.poll()
                got = c.poll_outcome()
                while got is not None:
                    self.assertNotIn(got[0], ended, "a call ended twice")
                    ended[got[0]] = got[1]
                    got = c.poll_outcome()
                if not killed and len(ended) >= 20:
                    first.kill()
                    killed = True
                time.sleep(0.005)
        self.assertEqual(len(ended), 40)
        for call_id, result in ended.items():
            if isinstance(result, cc.Answer):
                self.assertEqual(result.lines, ["n value %d" % started[call_id]])
            else:
                self.assertIn(result.kind, ("provider_lapsed", "timeout"), str(result))
                self.assertEqual(result.provider, first_id)


if __name__ == "__main__":
    unittest.main()
