"""Seals: Ed25519 (RFC 8032) in pure Python against the RFC's vectors and the
edge cases ed25519-dalek's `verify_strict` refuses, and the seal line read
exactly as crates/wire/src/seal.rs reads it, whatever bytes come.

Standard library only; run with the rest: python3 -m unittest discover -s python/tests -v
"""

import os
import random
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import colony_client as cc  # noqa: E402

# RFC 8032 section 7.1: TEST 1, 2, 3 and SHA(abc) (secret seed, public key, message, signature).
RFC8032 = [
    ("9d61b19deffd5a60ba844af492ec2cc44449c5697b326919703bac031cae7f60",
     "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a",
     "",
     "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b"),
    ("4ccd089b28ff96da9db6c346ec114e0f5b8a319f35aba624da8cf6ed4fb8a6fb",
     "3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c",
     "72",
     "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da085ac1e43e15996e458f3613d0f11d8c387b2eaeb4302aeeb00d291612bb0c00"),
    ("c5aa8df43f9f837bedb7442f31dcb7b166d38535076f094b85ce3a2e0b4458f7",
     "fc51cd8e6218a1a38da47ed00230f0580816ed13ba3303ac5deb911548908025",
     "af82",
     "6291d657deec24024827e69c3abe01a30ce548a284743a445e3680d7db5ac3ac18ff9b538d16f290ae67f760984dc6594a7c15e9716ed28dc027beceea1ec40a"),
    ("833fe62409237b9d62ec77587520911e9a759cec1d19755b7da901b96dca3d42",
     "ec172b93ad5e563bf4932c70e1245034c35467ef2efd4d64ebf819683467e2bf",
     "ddaf35a193617abacc417349ae20413112e6fa4e89a97ea20a9eeee64b55d39a2192992a274fc1a836ba3c23a3feebbd454d4423643ce80e2a9ac94fa54ca49f",
     "dc2a4459e7369633a52b1bf277839a00201009a3efbf3ecb69bea2186c26b58909351fc9ac90b3ecfdfbc7c66431e0303dca179c138ac17ad9bef1177331a704"),
]

PACKET = b"@ <murdoch.user.17.1> 0\ndone task 17 bidder r2\n"


def le(n):
    return n.to_bytes(32, "little")


def lenient_verify(public, message, signature):
    """Cofactorless RFC 8032 verification without the strict checks: what a
    forger hopes a receiver runs."""
    a = cc._pt_decode(public)
    s = int.from_bytes(signature[32:], "little")
    k = cc._h_int(signature[:32], public, message) % cc._L
    minus_a = (-a[0] % cc._P, a[1], a[2], -a[3] % cc._P)
    return cc._pt_encode(cc._pt_add(cc._base_mul(s), cc._pt_mul(k, minus_a))) == signature[:32]


class Ed25519(unittest.TestCase):
    def test_rfc8032_vectors(self):
        for seed, public, message, signature in RFC8032:
            seed, public, message, signature = map(bytes.fromhex, (seed, public, message, signature))
            self.assertEqual(cc.ed25519_public_key(seed), public)
            self.assertEqual(cc.ed25519_sign(seed, message), signature)
            self.assertTrue(cc.ed25519_verify(public, message, signature))
            self.assertFalse(cc.ed25519_verify(public, message + b"x", signature))
            for i in (0, 31, 32, 63):
                bad = bytearray(signature)
                bad[i] ^= 0x01
                self.assertFalse(cc.ed25519_verify(public, message, bytes(bad)))

    def test_a_signature_plus_the_group_order_is_refused(self):
        # [S + L]B = [S]B: a second valid-looking signature unless S must be below L.
        seed, public, message, signature = map(bytes.fromhex, RFC8032[1])
        s = int.from_bytes(signature[32:], "little")
        twin = signature[:32] + le(s + cc._L)
        self.assertTrue(lenient_verify(public, message, twin))
        self.assertFalse(cc.ed25519_verify(public, message, twin))

    def test_a_small_order_key_that_verifies_everything_is_refused(self):
        identity = le(1)  # the neutral point: [S]B - [k]A = [S]B whatever the message
        signature = identity + le(0)
        for message in (b"", b"anything", PACKET):
            self.assertTrue(lenient_verify(identity, message, signature))
            self.assertFalse(cc.ed25519_verify(identity, message, signature))
        # Every point of order 2, 4 or 8 is refused as a key, and as R.
        _, public, message, signature = map(bytes.fromhex, RFC8032[0])
        for t in self.torsion():
            self.assertTrue(cc._pt_small_order(t))
            self.assertFalse(cc.ed25519_verify(cc._pt_encode(t), message, signature))
            self.assertFalse(cc.ed25519_verify(public, message, cc._pt_encode(t) + signature[32:]))
        self.assertFalse(cc.ed25519_verify(bytes(32), message, signature))

    def test_non_canonical_encodings_do_not_decode(self):
        for y in (cc._P, cc._P + 1, cc._P + 2, 2 ** 255 - 1):
            self.assertIsNone(cc._pt_decode(le(y)))
        # x = 0 with its sign bit set: the neutral point spelled a second way.
        self.assertIsNone(cc._pt_decode(le(1 | 1 << 255)))
        _, public, message, signature = map(bytes.fromhex, RFC8032[0])
        self.assertFalse(cc.ed25519_verify(le(cc._P + 1), message, signature))
        self.assertFalse(cc.ed25519_verify(public, message, le(cc._P + 1) + signature[32:]))

    def test_a_key_with_a_small_order_component_is_taken_as_verify_strict_takes_it(self):
        # ed25519-dalek's verify_strict refuses small-order keys, not keys
        # with a torsion part; a signature made under A + T verifies when the
        # challenge is a multiple of T's order.
        t8 = next(t for t in self.torsion() if cc._pt_encode(cc._pt_double(cc._pt_double(t))) != le(1))
        a, prefix = cc._expand_seed(bytes(range(32)))
        mixed = cc._pt_encode(cc._pt_add(cc._base_mul(a), t8))
        seen = set()
        for i in range(200):
            message = b"m%d" % i
            r = cc._h_int(prefix, message) % cc._L
            big_r = cc._pt_encode(cc._base_mul(r))
            k = cc._h_int(big_r, mixed, message) % cc._L
            signature = big_r + le((r + k * a) % cc._L)
            ok = cc.ed25519_verify(mixed, message, signature)
            self.assertEqual(ok, k % 8 == 0, i)
            seen.add(ok)
            if seen == {True, False}:
                return
        self.fail("no challenge divisible by 8 in 200 tries")

    def test_bad_lengths_and_types_are_false_not_errors(self):
        _, public, message, signature = map(bytes.fromhex, RFC8032[0])
        self.assertFalse(cc.ed25519_verify(public[:31], message, signature))
        self.assertFalse(cc.ed25519_verify(public, message, signature[:63]))
        self.assertFalse(cc.ed25519_verify(None, message, signature))
        self.assertFalse(cc.ed25519_verify(public, message, 5.0))
        with self.assertRaises(ValueError):
            cc.Identity(b"short")

    def torsion(self):
        """The eight points of order dividing 8, found as [L]Q for points Q."""
        found = {}
        y = 2
        while len(found) < 8 and y < 10000:
            for sign in (0, 1 << 255):
                q = cc._pt_decode(le(y | sign))
                if q is not None:
                    t = cc._pt_mul(cc._L, q)
                    found[cc._pt_encode(t)] = t
            y += 1
        self.assertEqual(len(found), 8)
        return list(found.values())


class Seals(unittest.TestCase):
    def test_a_sealed_packet_opens_to_its_body_key_and_count(self):
        me = cc.Identity(bytes.fromhex(RFC8032[1][0]))
        self.assertEqual(me.key_hex, RFC8032[1][1])
        sealed = me.seal(PACKET)
        self.assertTrue(sealed.startswith(PACKET + b"seal n 1 key " + me.key_hex.encode() + b" sig "))
        self.assertEqual(len(sealed), len(PACKET) + 211)
        opened = cc.open_seal(sealed)
        self.assertEqual(opened, (PACKET, me.key, 1))
        self.assertEqual((opened.body, opened.key, opened.n), (PACKET, me.key, 1))
        self.assertEqual(cc.open_seal(me.seal(PACKET)).n, 2)
        self.assertEqual(cc.strip_seal(sealed), PACKET)
        self.assertEqual(cc.strip_seal(PACKET), PACKET)
        # A sealed packet is still a packet, its seal an ordinary last line.
        self.assertEqual(cc.parse(sealed).labels(), ["done", "seal"])
        # The same seed and count seal the same bytes (Ed25519 is deterministic).
        again = cc.Identity(bytes.fromhex(RFC8032[1][0]))
        self.assertEqual(again.seal(PACKET), sealed)
        # A packet without its last newline gets one before the seal.
        self.assertEqual(cc.open_seal(again.seal(PACKET[:-1])).body, PACKET)
        self.assertNotIn(RFC8032[1][0], repr(me))

    def test_the_signature_covers_every_byte_before_it(self):
        me = cc.Identity(bytes(32))
        sealed = me.seal(PACKET)
        signed, sig = sealed[:-129], bytes.fromhex(sealed[-129:-1].decode())
        self.assertTrue(signed.endswith(b" sig "))
        self.assertTrue(cc.ed25519_verify(me.key, signed, sig))

    def test_fingerprint_is_the_first_8_bytes_of_sha256_big_endian(self):
        import hashlib

        key = bytes.fromhex(RFC8032[0][1])
        want = int(hashlib.sha256(key).hexdigest()[:16], 16)
        self.assertEqual(cc.fingerprint(key), want)
        self.assertEqual(cc.Identity(bytes.fromhex(RFC8032[0][0])).fingerprint, want)

    def test_any_change_to_a_sealed_packet_is_refused(self):
        me = cc.Identity(bytes([3]) * 32)
        sealed = me.seal(PACKET)
        for i in range(len(sealed) - 1):
            for bit in (0x01, 0x20):
                bad = bytearray(sealed)
                bad[i] ^= bit
                with self.assertRaises(cc.SealError, msg="byte %d" % i):
                    cc.open_seal(bytes(bad))

    def test_another_key_cannot_take_a_seal_over(self):
        real, forger = cc.Identity(bytes([4]) * 32), cc.Identity(bytes([5]) * 32)
        sealed = real.seal(PACKET)
        forged = sealed.replace(real.key_hex.encode(), forger.key_hex.encode())
        with self.assertRaises(cc.SealError) as e:
            cc.open_seal(forged)
        self.assertEqual(e.exception.kind, "bad_signature")

    def test_unsealed_and_malformed_lines_are_told_apart(self):
        key, sig = "0" * 64, "0" * 128
        real = cc.Identity(bytes(32)).seal(PACKET).decode()
        rkey, rsig = real.split()[-3], real.split()[-1]
        cases = [
            (PACKET, "missing"),
            (b"", "missing"),
            (b"\n", "missing"),
            ("seal n 01 key %s sig %s\n" % (key, sig), "malformed"),
            ("seal n 1 key %s sig %s\n" % (key, sig), "bad_signature"),  # all zero: a small-order point
            ("seal n 1 key %s sig %s\n" % ("G" * 64, sig), "malformed"),
            ("seal n 1 key %s sig %s\n" % (rkey.upper(), rsig), "malformed"),
            ("seal n 1 key %s sig %s\n" % (rkey, rsig.upper()), "malformed"),
            ("xseal n 1 key %s sig %s\n" % (key, sig), "missing"),
            ("seal n  key %s sig %s\n" % (key, sig), "malformed"),
            ("seal n 1 key %s sig %s\n" % (key[1:], sig), "missing"),
            ("seal n 1 key %s sig %s0\n" % (key, sig), "missing"),
            ("seal n 1 key %s sig %s\n\n" % (key, sig), "missing"),
            ("seal n 1 key %s  sig %s\n" % (key, sig), "missing"),
            ("seal n 1 key %s sig %s" % (key, sig), "bad_signature"),  # the last newline is optional
            ("seal n 18446744073709551616 key %s sig %s\n" % (key, sig), "malformed"),
            ("seal n 18446744073709551615 key %s sig %s\n" % (key, sig), "bad_signature"),
            ("seal n 123456789012345678901 key %s sig %s\n" % (key, sig), "malformed"),
            ("seal n %s key %s sig %s\n" % ("9" * 5000, key, sig), "malformed"),
            ("seal n 1 key %s sig %s\n" % ("ff" * 31 + "7f", sig), "bad_key"),  # y >= p
            ("seal n 1 key %s sig %s\n" % (rkey, "ff" * 64), "bad_signature"),
        ]
        for line, want in cases:
            line = line.encode() if isinstance(line, str) else line
            for packet in (line, PACKET + line) if line.startswith(b"seal") else (line,):
                with self.assertRaises(cc.SealError, msg=repr(packet)) as e:
                    cc.open_seal(packet)
                self.assertEqual(e.exception.kind, want, repr(packet))
        # The seal line must start a line.
        with self.assertRaises(cc.SealError) as e:
            cc.open_seal(PACKET[:-1] + b" " + real.encode()[len(PACKET):])
        self.assertEqual(e.exception.kind, "missing")

    def test_any_bytes_raise_only_a_seal_error(self):
        rng = random.Random(7)
        me = cc.Identity(bytes([9]) * 32)
        sealed = me.seal(PACKET)
        alphabet = b"seal nkyig0123456789abcdefABCDEF \n\x00\xff"
        for i in range(3000):
            kind = i % 4
            if kind == 0:
                data = bytes(rng.randrange(256) for _ in range(rng.randrange(0, 400)))
            elif kind == 1:
                data = bytes(rng.choice(alphabet) for _ in range(rng.randrange(190, 260)))
            elif kind == 2:
                cut = rng.randrange(len(sealed))
                data = sealed[:cut] + bytes([rng.randrange(256)]) + sealed[cut + 1:]
            else:
                data = sealed[:rng.randrange(len(sealed))] + sealed[rng.randrange(len(sealed)):]
            try:
                cc.open_seal(data)
            except cc.SealError:
                pass
            cc.strip_seal(data)
        # Text is read as its UTF-8 bytes.
        self.assertEqual(cc.open_seal(sealed.decode()).body, PACKET)

    def test_a_seal_must_fit_in_a_datagram(self):
        me = cc.Identity()
        big = b"@ <x> 0\nt v " + b"a" * (cc.MAX_PACKET - 12 - 211) + b"\n"
        with self.assertRaises(cc.ParseError):
            me.seal(big)
        self.assertEqual(me.n, 0)
        fits = b"@ <x> 0\nt v " + b"a" * (cc.MAX_PACKET - 13 - 211) + b"\n"
        self.assertEqual(len(me.seal(fits)), cc.MAX_PACKET)
        cc.parse(me.seal(fits[:-1000]))

    def test_fresh_identities_differ(self):
        a, b = cc.Identity(), cc.Identity()
        self.assertNotEqual(a.key, b.key)
        self.assertEqual(len(a.key), 32)


if __name__ == "__main__":
    unittest.main()
