"""colony_client: a Python client for the colony hub, in one file, standard library only.

The packet format (the same text every colony process speaks)::

    @ <vision_out> 0
    ball x 5.3 y -2.5
    blue id 0 x 15.2 y -98.3 pose (xh 1.0 yh 0.0)
    note text "kick \\"off\\""

* :func:`parse` reads a datagram exactly as the Rust parser (``colony_wire``)
  does, with the same errors at the same line and (byte) column.
* :func:`build` / :func:`format_packet` write packets that every reader accepts.
* :class:`Client` talks to a hub over a non-blocking UDP socket. It never
  starts a thread and never owns the loop: wait on :meth:`Client.fileno` until
  :meth:`Client.next_deadline`, then call :meth:`Client.poll` and
  :meth:`Client.recv`. It follows the hub's lease and cookie by itself, signs
  every packet when given the hub's key, and skips (and counts) datagrams that
  do not parse.
* :class:`Identity` seals packets (an Ed25519 signature as their last line,
  as ``colony_wire::seal`` writes it) and :func:`open_seal` checks them: what
  MURDOCH (:func:`announce_task`) and request and reply (:class:`Caller`,
  :class:`Provider`) use to know which process said what.

Values become plain Python: ``int`` for a bare token Rust reads as an ``i64``,
``float`` for any other bare token Rust reads as an ``f64`` (``1e5``, ``.5``,
``5.``, ``inf``, ``-Infinity``, ``NaN``, ...), ``str`` for every other bare
token and for every quoted string (``"5"`` stays the string ``'5'``), and
``dict`` for a parenthesised group.

Python 3.8 or later.
"""

import errno
import hashlib
import hmac
import ipaddress
import math
import os
import random
import re
import select
import socket
import sys
import time
from collections import deque

__all__ = [
    "MAX_PACKET",
    "MAX_SUBJECTS",
    "MAX_SUBJECT_LEN",
    "MAX_DEPTH",
    "HUB_SUBJECT",
    "DEFAULT_HUB",
    "ParseError",
    "Packet",
    "parse",
    "build",
    "format_packet",
    "NO_COOKIE",
    "Session",
    "Signer",
    "read_key",
    "Identity",
    "Sealed",
    "SealError",
    "open_seal",
    "strip_seal",
    "fingerprint",
    "ed25519_public_key",
    "ed25519_sign",
    "ed25519_verify",
    "Client",
    "SERVICE_PREFIX",
    "REPLY_PREFIX",
    "MAX_SERVICE_LEN",
    "ACK_WAIT",
    "CallError",
    "Answer",
    "Caller",
    "Call",
    "Provider",
    "CallClient",
    "ServeClient",
]

#: The largest packet: the payload of one UDP datagram over IPv4.
MAX_PACKET = 65507
#: The most subjects one header may name.
MAX_SUBJECTS = 16
#: The longest subject name, in bytes.
MAX_SUBJECT_LEN = 64
#: How deep groups may nest.
MAX_DEPTH = 32
#: The reserved subject that carries control requests and the hub's replies.
HUB_SUBJECT = "hub"
#: Where a hub listens unless told otherwise.
DEFAULT_HUB = ("127.0.0.1", 7400)

_I64_MIN = -(2 ** 63)
_I64_MAX = 2 ** 63 - 1
_I32_MIN = -(2 ** 31)
_I32_MAX = 2 ** 31 - 1
# The most digits an i64 has (after any leading zeros).
_I64_DIGITS = 19

# --------------------------------------------------------------------------- errors

_MESSAGES = {
    "too_large": "packet is {len} bytes, more than the 65507 a UDP datagram can carry",
    "empty": "empty packet: expected a header `@ <subject> priority`",
    "not_utf8": "packet is not valid UTF-8",
    "bad_header": "bad header: expected {what}",
    "bad_subject": "bad subject `{name}`: subjects are 1 to 64 characters of A-Z a-z 0-9 _ - . : /",
    "duplicate_subject": "subject `<{name}>` appears twice in the header",
    "bad_priority": "priority `{text}` is not a 32-bit integer",
    "control_char": "control character 0x{byte:02x} is not allowed",
    "expected_label": "expected a line label, found `{char}`",
    "expected_name": "expected a field name, found `{char}`",
    "missing_value": "field `{name}` has no value",
    "duplicate_name": "duplicate name `{name}`: a name may appear once per line or group",
    "unclosed_group": "unbalanced parentheses: `(` not closed before the end of the line",
    "unmatched_close": "unbalanced parentheses: `)` without a matching `(`",
    "unterminated_string": 'unterminated string: no closing `"` before the end of the line',
    "bad_escape": 'unknown escape `\\{char}` (known: \\" \\\\ \\n \\r \\t)',
    "too_deep": "groups nested deeper than 32",
}


class ParseError(ValueError):
    """A malformed packet: what was wrong and where.

    ``kind`` names the problem (the Rust ``ErrorKind`` in snake case:
    ``too_large``, ``empty``, ``not_utf8``, ``bad_header``, ``bad_subject``,
    ``duplicate_subject``, ``bad_priority``, ``control_char``,
    ``expected_label``, ``expected_name``, ``missing_value``,
    ``duplicate_name``, ``unclosed_group``, ``unmatched_close``,
    ``unterminated_string``, ``bad_escape``, ``too_deep``); ``line`` and
    ``column`` are 1-based, the column counted in bytes as in Rust;
    ``message`` says what was wrong (``str(e)`` adds the position, worded as
    the Rust ``Display``); ``detail`` holds the kind's data (the name, the
    character, the expected text...).
    """

    def __init__(self, kind, line, column, **detail):
        self.kind = kind
        self.line = line
        self.column = column
        self.detail = detail
        self.message = _MESSAGES[kind].format(**detail)
        super().__init__("line {}, column {}: {}".format(line, column, self.message))

    def __reduce__(self):
        return (_make_error, (self.kind, self.line, self.column, self.detail))


def _make_error(kind, line, column, detail):
    return ParseError(kind, line, column, **detail)


# --------------------------------------------------------------------------- scanning

# Bare tokens: every character but controls (< 0x20, 0x7f), blank, `"`, `(`, `)`.
# Every non-ASCII character is bare, as every byte >= 0x80 is in Rust. Lone
# surrogates are no characters in UTF-8 (decoding never yields them), so a str
# holding one is no token that can be written.
_BARE_RUN = re.compile(r'[^\x00-\x20"()\x7f\ud800-\udfff]+')
# The fast run inside a quoted string: anything but controls (a raw tab is kept), `"`, `\`.
_QUOTE_RUN = re.compile(r'[^\x00-\x08\x0a-\x1f"\\\x7f]*')
_BLANKS = re.compile(r"[ \t]*")
_SUBJECT = re.compile(r"[A-Za-z0-9_\-.:/]{1,64}")
_INTEGER = re.compile(r"[+-]?[0-9]+")
# Rust's `f64::from_str`, letters in any case.
_FLOAT = re.compile(
    r"[+-]?(?:inf|infinity|nan|(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:e[+-]?[0-9]+)?)",
    re.IGNORECASE | re.ASCII,
)
_SURROGATE = re.compile(r"[\ud800-\udfff]")
_ESCAPE = re.compile(r"\\(.)", re.DOTALL)
_UNESCAPE = {"n": "\n", "r": "\r", "t": "\t"}

_BARE, _QUOTED, _OPEN, _CLOSE, _EOL = range(5)


def _is_control(ch):
    o = ord(ch)
    return o < 0x20 or o == 0x7F


def is_bare_token(s):
    """Whether ``s`` can be written as a bare token (no quoting needed)."""
    return isinstance(s, str) and _BARE_RUN.fullmatch(s) is not None


def is_subject(s):
    """Whether ``s`` is a valid subject name (without its angle brackets)."""
    return isinstance(s, str) and _SUBJECT.fullmatch(s) is not None


def _integer(token, lo, hi):
    """The token as Rust's ``i64``/``i32`` ``from_str`` reads it (an optional sign,
    then ASCII digits) when it lies in ``lo..=hi``, else None.

    Python's ``int()`` refuses strings of more than 4,300 digits with a
    ValueError (Python 3.11), so a token is measured before it is converted:
    past 19 significant digits it is out of range whatever it says.
    """
    if _INTEGER.fullmatch(token) is None:
        return None
    digits = token.lstrip("+-").lstrip("0") or "0"
    if len(digits) > _I64_DIGITS:
        return None
    v = int(digits)
    if token[0] == "-":
        v = -v
    return v if lo <= v <= hi else None


def _value_of(token):
    """A bare token as plain Python: int, float or str, as Rust's getters read it."""
    v = _integer(token, _I64_MIN, _I64_MAX)
    if v is not None:
        return v
    if _FLOAT.fullmatch(token):
        # float() has no digit limit and, like Rust, rounds any length correctly
        # (a 5,000-digit integer is inf in both).
        return float(token)
    return token


def _unescape(raw):
    if "\\" not in raw:
        return raw
    return _ESCAPE.sub(lambda m: _UNESCAPE.get(m.group(1), m.group(1)), raw)


class _Scanner:
    """A cursor over the packet text that knows its line and column (a port of scan.rs)."""

    __slots__ = ("src", "n", "pos", "line", "line_start", "prev")

    def __init__(self, src, pos=0, line=1, line_start=0):
        self.src = src
        self.n = len(src)
        self.pos = pos
        self.line = line
        self.line_start = line_start
        # The line just ended, so an error found at its end is reported on it.
        self.prev = (line, line_start)

    def at_end(self):
        return self.pos >= self.n

    def error(self, pos, kind, **detail):
        if pos < self.line_start:
            line, start = self.prev
        else:
            line, start = self.line, self.line_start
        # Columns count bytes, as in Rust.
        column = len(self.src[start:pos].encode("utf-8")) + 1 if pos > start else 1
        return ParseError(kind, line, column, **detail)

    def char_at(self, pos):
        return self.src[pos] if pos < self.n else "\ufffd"

    def _new_line(self, next_start):
        self.prev = (self.line, self.line_start)
        self.pos = next_start
        self.line += 1
        self.line_start = next_start

    def skip_ws(self):
        self.pos = _BLANKS.match(self.src, self.pos).end()

    def _take_eol(self):
        """Consumes the line end (``\\n``, ``\\r\\n`` or the end) if it is next."""
        pos = self.pos
        if pos >= self.n:
            return True
        c = self.src[pos]
        if c == "\n":
            self._new_line(pos + 1)
            return True
        if c == "\r" and self.src.startswith("\n", pos + 1):
            self._new_line(pos + 2)
            return True
        if _is_control(c):
            raise self.error(pos, "control_char", byte=ord(c))
        return False

    def next(self):
        """The next token after any blanks: ``(kind, start, text)``."""
        self.skip_ws()
        start = self.pos
        if self._take_eol():
            return _EOL, start, None
        c = self.src[start]
        if c == "(":
            self.pos = start + 1
            return _OPEN, start, None
        if c == ")":
            self.pos = start + 1
            return _CLOSE, start, None
        if c == '"':
            return self._quoted(start)
        end = _BARE_RUN.match(self.src, start).end()
        self.pos = end
        return _BARE, start, self.src[start:end]

    def _quoted(self, start):
        src, n = self.src, self.n
        p = start + 1
        while True:
            p = _QUOTE_RUN.match(src, p).end()
            if p >= n or src[p] in "\n\r":
                raise self.error(start, "unterminated_string")
            c = src[p]
            if c == '"':
                self.pos = p + 1
                return _QUOTED, start, src[start + 1 : p]
            if c == "\\":
                if p + 1 >= n or src[p + 1] in "\n\r":
                    raise self.error(start, "unterminated_string")
                if src[p + 1] in '"\\nrt':
                    p += 2
                    continue
                raise self.error(p, "bad_escape", char=src[p + 1])
            raise self.error(p, "control_char", byte=ord(c))


def _decode(data):
    """Checks size and UTF-8, as the Rust parser does before anything else."""
    if isinstance(data, (bytearray, memoryview)):
        data = bytes(data)
    elif isinstance(data, str):
        data = data.encode("utf-8")
    elif not isinstance(data, bytes):
        raise TypeError("parse() takes bytes, not {}".format(type(data).__name__))
    if len(data) > MAX_PACKET:
        raise ParseError("too_large", 1, 1, len=len(data))
    if not data:
        raise ParseError("empty", 1, 1)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        good = data[: e.start]
        line = good.count(b"\n") + 1
        line_start = good.rfind(b"\n") + 1
        raise ParseError("not_utf8", line, len(good) - line_start + 1) from None


def _header(s):
    """Reads ``@ <subject>... priority``; returns (subjects, priority)."""
    src, n = s.src, s.n
    if src[0] != "@":
        raise s.error(0, "bad_header", what="`@` at the start of the packet")
    s.pos = 1
    if n < 2 or src[1] not in " \t":
        raise s.error(1, "bad_header", what="a blank after `@`")
    s.skip_ws()
    subjects = []
    while s.pos < n and src[s.pos] == "<":
        open_at = s.pos
        close = src.find(">", open_at)
        newline = src.find("\n", open_at)
        if close < 0 or 0 <= newline < close:
            raise s.error(open_at, "bad_header", what="`>` to close the subject")
        name = src[open_at + 1 : close]
        if not is_subject(name):
            raise s.error(open_at, "bad_subject", name=name)
        if name in subjects:
            raise s.error(open_at, "duplicate_subject", name=name)
        if len(subjects) == MAX_SUBJECTS:
            raise s.error(open_at, "bad_header", what="at most 16 subjects")
        subjects.append(name)
        s.pos = close + 1
        c = src[s.pos] if s.pos < n else None
        if c is None or c in "\r\n":
            raise s.error(s.pos, "bad_header", what="an integer priority after the subjects")
        if c not in " \t":
            raise s.error(s.pos, "bad_header", what="a blank after the subject")
        s.skip_ws()
    if not subjects:
        raise s.error(s.pos, "bad_header", what="a `<subject>`")
    prio_at = s.pos
    kind, _, text = s.next()
    if kind != _BARE:
        raise s.error(prio_at, "bad_header", what="an integer priority")
    priority = _integer(text, _I32_MIN, _I32_MAX)
    if priority is None:
        raise s.error(prio_at, "bad_priority", text=text)
    end_at = s.pos
    if s.next()[0] != _EOL:
        raise s.error(end_at, "bad_header", what="the end of the header after the priority")
    return subjects, priority


def _body(s):
    """Reads every line; returns a list of (label, dict)."""
    lines = []
    while not s.at_end():
        kind, p, label = s.next()
        if kind == _EOL:
            continue
        if kind != _BARE:
            raise s.error(p, "expected_label", char=s.char_at(p))
        fields = {}
        stack = [fields]
        while True:
            kind, p, name = s.next()
            if kind == _EOL:
                if len(stack) > 1:
                    raise s.error(p, "unclosed_group")
                break
            if kind == _CLOSE:
                if len(stack) == 1:
                    raise s.error(p, "unmatched_close")
                stack.pop()
                continue
            if kind != _BARE:
                raise s.error(p, "expected_name", char=s.char_at(p))
            here = stack[-1]
            if name in here:
                raise s.error(p, "duplicate_name", name=name)
            vkind, vp, text = s.next()
            if vkind == _BARE:
                here[name] = _value_of(text)
            elif vkind == _QUOTED:
                here[name] = _unescape(text)
            elif vkind == _OPEN:
                if len(stack) - 1 >= MAX_DEPTH:
                    raise s.error(vp, "too_deep")
                group = {}
                here[name] = group
                stack.append(group)
            else:
                raise s.error(p, "missing_value", name=name)
        lines.append((label, fields))
    return lines


# --------------------------------------------------------------------------- packets


class Packet:
    """A parsed packet.

    ``subjects`` is the list of subjects in the order written, ``priority`` an
    int, ``lines`` a list of ``(label, dict)`` in order (blank lines skipped;
    repeated labels are the format's arrays), ``text`` the packet as received.
    ``str(packet)`` is the canonical form, byte for byte what the Rust
    ``Display`` (and so ``colony sub``) writes.
    """

    __slots__ = ("subjects", "priority", "lines", "text", "_body")

    def __init__(self, subjects, priority, lines, text=None, body=None):
        self.subjects = list(subjects)
        self.priority = priority
        self.lines = list(lines)
        self.text = text
        self._body = body

    def line(self, label):
        """The fields of the first line with this label, or None."""
        for lab, fields in self.lines:
            if lab == label:
                return fields
        return None

    def lines_labelled(self, label):
        """The fields of every line with this label, in order."""
        return [fields for lab, fields in self.lines if lab == label]

    def labels(self):
        return [lab for lab, _ in self.lines]

    def has_subject(self, subject):
        return subject in self.subjects

    def is_control(self):
        """Whether this is a packet to (or from) the hub itself."""
        return self.subjects == [HUB_SUBJECT]

    def to_bytes(self):
        """The packet written again (values re-encoded, see :func:`build`)."""
        return build(self.subjects, self.priority, self.lines)

    def __bytes__(self):
        if self.text is not None:
            return self.text.encode("utf-8")
        return self.to_bytes()

    def __eq__(self, other):
        if not isinstance(other, Packet):
            return NotImplemented
        return (self.subjects, self.priority, self.lines) == (
            other.subjects,
            other.priority,
            other.lines,
        )

    __hash__ = None

    def __repr__(self):
        return "Packet(subjects={!r}, priority={!r}, lines={!r})".format(
            self.subjects, self.priority, self.lines
        )

    def __str__(self):
        if self.text is None or self._body is None:
            return format_packet(self.subjects, self.priority, self.lines)
        out = ["@"]
        for subject in self.subjects:
            out.append(" <" + subject + ">")
        out.append(" {}\n".format(self.priority))
        s = _Scanner(self.text, self._body, 2, self._body)
        while not s.at_end():
            kind, _, label = s.next()
            if kind == _EOL:
                continue
            out.append(label)
            after_open = False
            while True:
                kind, _, text = s.next()
                if kind == _EOL:
                    break
                if kind == _CLOSE:
                    out.append(")")
                    after_open = False
                    continue
                if not after_open:
                    out.append(" ")
                if kind == _OPEN:
                    out.append("(")
                    after_open = True
                    continue
                out.append(text if kind == _BARE else '"' + text + '"')
                after_open = False
            out.append("\n")
        return "".join(out)


def parse(data):
    """Parses one datagram (bytes) into a :class:`Packet`, or raises :class:`ParseError`.

    Exactly the Rust grammar: the header ``@ <subject>... priority`` (1 to 16
    distinct subjects of 1 to 64 characters ``A-Z a-z 0-9 _ - . : /``, a
    32-bit priority), then lines of ``label name value ...``; a value is a bare
    token, a quoted string (escapes ``\\" \\\\ \\n \\r \\t``) or a group
    ``( name value ... )`` nested at most 32 deep; a name appears once per line
    or group; ``\\r\\n`` ends a line like ``\\n``; blank lines are skipped; at
    most 65507 bytes of UTF-8.
    """
    text = _decode(data)
    s = _Scanner(text)
    subjects, priority = _header(s)
    body = s.pos
    lines = _body(s)
    return Packet(subjects, priority, lines, text, body)


# --------------------------------------------------------------------------- writing


# What a quoted string cannot hold, escapes and all: the control characters
# with no escape, and lone surrogates (no UTF-8 for them).
_UNWRITABLE = re.compile(r"[\x00-\x08\x0b-\x0c\x0e-\x1f\x7f\ud800-\udfff]")


def _quote(s):
    bad = _UNWRITABLE.search(s)
    if bad is not None:
        # No packet reads back as this string, so writing a stand-in (as the
        # Rust builder does, U+FFFD) would send something else than asked.
        raise ValueError(
            "string {!r} holds {!r} at {}: no packet can carry it (only \\n \\r \\t "
            "have escapes)".format(s if len(s) <= 40 else s[:40] + "...", bad.group(), bad.start())
        )
    out = ['"']
    for ch in s:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\r":
            out.append("\\r")
        elif ch == "\t":
            out.append("\\t")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _write_value(value, depth):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        if not _I64_MIN <= value <= _I64_MAX:
            # Such a token reads back as a float, never as this int.
            raise ValueError("integer {} does not fit in 64 bits".format(value))
        # int's own text, whatever a subclass (an IntEnum) prints.
        return int.__repr__(value)
    if isinstance(value, float):
        # repr is the shortest text that reads back to the same float.
        return float.__repr__(value)
    if isinstance(value, str):
        # Bare only when it reads back as this very string (not as a number).
        if is_bare_token(value) and isinstance(_value_of(value), str):
            return value
        return _quote(value)
    if isinstance(value, dict):
        if depth >= MAX_DEPTH:
            raise ValueError("groups nested deeper than {}".format(MAX_DEPTH))
        return "(" + _write_fields(value, depth + 1) + ")"
    raise TypeError(
        "cannot write a {} as a packet value (use int, float, str, bool or dict)".format(
            type(value).__name__
        )
    )


def _write_fields(fields, depth):
    if fields is None:
        return ""
    items = fields.items() if isinstance(fields, dict) else fields
    parts = []
    seen = set()
    for name, value in items:
        if not is_bare_token(name):
            raise ValueError("field name {!r} is not a bare token".format(name))
        if name in seen:
            raise ValueError("duplicate field name {!r}".format(name))
        seen.add(name)
        parts.append(name + " " + _write_value(value, depth))
    return " ".join(parts)


def _subject_list(subjects):
    if isinstance(subjects, str):
        subjects = [subjects]
    out = []
    for s in subjects:
        if isinstance(s, str) and s.startswith("<") and s.endswith(">"):
            s = s[1:-1]
        if not is_subject(s):
            raise ValueError(
                "{!r} is not a subject: use 1 to 64 characters of A-Z a-z 0-9 _ - . : /".format(s)
            )
        out.append(s)
    if not out:
        raise ValueError("a packet needs at least one subject")
    return out


def _line_items(lines):
    if lines is None:
        return []
    if isinstance(lines, dict):
        items = []
        for label, fields in lines.items():
            if isinstance(fields, list):
                items.extend((label, f) for f in fields)
            else:
                items.append((label, fields))
        return items
    return list(lines)


def format_packet(subjects, priority=0, lines=()):
    """Writes a packet as text (see :func:`build`), checked by :func:`parse`."""
    subjects = _subject_list(subjects)
    if isinstance(priority, bool) or not isinstance(priority, int):
        raise TypeError("the priority is an int")
    if not _I32_MIN <= priority <= _I32_MAX:
        raise ValueError("priority {} does not fit in 32 bits".format(priority))
    out = ["@"]
    for s in subjects:
        out.append(" <" + s + ">")
    out.append(" {}\n".format(priority))
    for item in _line_items(lines):
        if isinstance(item, str):
            # A line written by hand, such as "ball x 5.3 y -2.5".
            if _SURROGATE.search(item) is not None:
                raise ValueError("line {!r} holds a lone surrogate: it has no UTF-8".format(item))
            out.append(item if item.endswith("\n") else item + "\n")
            continue
        label, fields = item
        if not is_bare_token(label):
            raise ValueError("line label {!r} is not a bare token".format(label))
        written = _write_fields(fields, 0)
        out.append(label + (" " + written if written else "") + "\n")
    text = "".join(out)
    parse(text.encode("utf-8"))
    return text


def build(subjects, priority=0, lines=()):
    """The bytes of a packet, ready to send.

    ``subjects`` is one subject or a list (a subject set); ``lines`` a list of
    ``(label, fields)`` where ``fields`` is a dict (or a list of pairs, or
    None), or a str holding a line written by hand; a dict ``{label: fields or
    [fields, ...]}`` is accepted too. Values: int (64-bit), float (written with
    ``repr`` so it reads back to the same float), bool (``true``/``false``),
    str (bare when it is a bare token that reads back as that string, quoted and
    escaped otherwise), dict (a group). The result is checked with
    :func:`parse`; a problem raises ValueError, TypeError or ParseError.

    What it writes parses back to the same values (``True`` and ``False``
    excepted, which read back as the strings ``'true'`` and ``'false'``), and
    it refuses exactly what no packet can carry: an int outside 64 bits (it
    would read back as a float), a string with a control character other than
    ``\\n \\r \\t`` (there is no escape for it), a name that is no bare token,
    groups deeper than 32, more than 65507 bytes.
    """
    return format_packet(subjects, priority, lines).encode("utf-8")


# --------------------------------------------------------------------------- control


def _control(*lines):
    return ("@ <hub> 0\n" + "".join(l + "\n" for l in lines)).encode("ascii")


def parse_status(packet):
    """The hub's status report as a dict (see :meth:`Client.status`)."""
    report = {
        "uptime_ms": 0,
        "lease_ms": 0,
        "min_priority": 0,
        "client_count": 0,
        "truncated": False,
        "drops": {},
        "channels": [],
        "clients": [],
    }
    for label, f in packet.lines:
        if label == "status":
            report["uptime_ms"] = f.get("uptime_ms")
            report["lease_ms"] = f.get("lease_ms")
            report["min_priority"] = f.get("min_priority")
            report["client_count"] = f.get("clients")
            report["truncated"] = f.get("truncated") not in (0, None)
        elif label == "drop":
            report["drops"][str(f.get("reason"))] = f.get("count")
        elif label == "channel":
            report["channels"].append(
                {"ch": str(f.get("ch")), "packets": f.get("packets"), "bytes": f.get("bytes")}
            )
        elif label == "client":
            subs = f.get("subs")
            report["clients"].append(
                {
                    "addr": str(f.get("addr")),
                    "idle_ms": f.get("idle_ms"),
                    "subs": dict(subs) if isinstance(subs, dict) else {},
                    "about": str(f.get("about") or ""),
                }
            )
    return report


# --------------------------------------------------------------------------- session

#: Requests sent this recently are sent again when the hub answers with a
#: cookie instead (it did not act on them).
_RESEND_WITHIN = 2.0

#: A second cookie this soon after the last is not taken.
_COOKIE_EVERY = 0.25

#: The shortest lease a hub grants, and a client believes (milliseconds).
MIN_LEASE_MS = 100

#: The cookie a client sends before the hub has given it one.
NO_COOKIE = "0" * 16
_COOKIE = re.compile(r"[0-9a-f]{16}")
# The shortest refresh interval a lease can ask for: a hub that grants a lease
# of 0 ms (or a few) must not make the client send in a busy loop.
_MIN_REFRESH = 0.01


def _first_line_raw(packet):
    """The label of the packet's first line and its top-level bare and quoted
    values as written (not converted: a cookie of 16 decimal digits is text,
    and ``1e34567890123456`` would be a float)."""
    s = _Scanner(packet.text, packet._body, 2, packet._body)
    while not s.at_end():
        kind, _, label = s.next()
        if kind == _EOL:
            continue
        fields = {}
        depth = 0
        name = None
        while True:
            kind, _, text = s.next()
            if kind == _EOL:
                return label, fields
            if kind == _OPEN:
                depth += 1
                name = None
            elif kind == _CLOSE:
                depth -= 1
            elif depth == 0:
                if name is None:
                    name = text
                else:
                    fields[name] = text if kind == _BARE else None
                    name = None
    return None, {}


class _Subscription:
    __slots__ = ("subject", "added", "last_data", "last_request")

    def __init__(self, subject, now):
        self.subject = subject
        self.added = now
        self.last_data = None
        self.last_request = None

    def due(self, refresh, resubscribe_after):
        """When this subscription next needs a subscribe request: at once when
        new; then every ``refresh`` while data flows, or every
        ``resubscribe_after`` while the channel is silent."""
        asked = self.last_request
        if asked is None:
            return self.added
        heard = asked if self.last_data is None else max(self.last_data, asked)
        return min(asked + refresh, heard + resubscribe_after)


class Session:
    """The client's side of the protocol with no socket: a port of
    ``crates/client/src/session.rs``. Times are ``time.monotonic()`` seconds.

    Feed it time (:meth:`handle_timeout`) and received datagrams
    (:meth:`handle_datagram`); take what it wants sent from
    :meth:`poll_transmit`.

    Two things the hub asks of every client are kept here, so an application
    never sees them:

    * the lease: once the hub has said ``lease ms N``, each subscription is
      refreshed at least three times per lease (``min(refresh, N / 3)``);
    * the cookie: every control packet carries ``cookie v H``, the last
      cookie the hub sent (:data:`NO_COOKIE` before that), since the hub acts
      only on requests from an address that proved it receives there; when
      the hub answers with a new cookie, every subscription, and every other
      request sent in the last two seconds, is sent again at once, with it.
    """

    def __init__(self, now=None, refresh=3.0, resubscribe_after=1.0, unreachable_after=10.0):
        now = time.monotonic() if now is None else now
        self.refresh = refresh
        self.resubscribe_after = resubscribe_after
        self.unreachable_after = unreachable_after
        self._subs = []
        self._outbox = deque()
        self.started = now
        self.last_from_hub = None
        #: The hub's lease in milliseconds, once it has told us.
        self.lease_ms = None
        #: How many lease replies have arrived.
        self.leases = 0
        #: The cookie sent with every subscription: the hub's last, 16 hex digits.
        self.cookie = NO_COOKIE
        #: How many cookie replies have arrived.
        self.cookies = 0
        # The raised minimum priority this client keeps, and when it last asked.
        self._min_priority = None
        # The latest time any call gave, and one-off requests lately sent
        # (sent again with a fresh cookie: the hub did not act on them).
        self._clock = now
        self._recent = []
        self._last_asked = None
        self._last_cookie = None

    def subscriptions(self):
        return [s.subject for s in self._subs]

    def subscribe(self, now, subject):
        self._clock = max(self._clock, now)
        if not any(s.subject == subject for s in self._subs):
            self._subs.append(_Subscription(subject, now))

    def unsubscribe(self, subject):
        for i, s in enumerate(self._subs):
            if s.subject == subject:
                del self._subs[i]
                self.request("unsubscribe ch " + subject)
                return True
        return False

    def unsubscribe_all(self):
        self._subs = []
        self.request("unsubscribe_all")

    def control_packet(self, *lines):
        """A control packet of these request lines, with the cookie line first,
        as the hub requires."""
        return _control("cookie v " + self.cookie, *lines)

    def request(self, *lines):
        """Queues a control packet of these request lines (``status``, ...)."""
        self._outbox.append(self.control_packet(*lines))
        self._last_asked = self._clock
        if not any(_is_subscribe(line) for line in lines):
            clock = self._clock
            self._recent = [(t, l) for (t, l) in self._recent if clock - t < _RESEND_WITHIN]
            self._recent.append((clock, lines))

    def refresh_interval(self):
        """How often a subscription is refreshed while data flows: ``refresh``,
        or a third of the hub's lease once it has told us, if that is shorter."""
        if self.lease_ms is None:
            return self.refresh
        return max(_MIN_REFRESH, min(self.refresh, self.lease_ms / 3000.0))

    def set_min_priority(self, now, value):
        """Asks the hub to drop every published packet below ``value``, and
        keeps asking: a raised minimum is a lease that lapses unless refreshed
        (RULES point 3), so a console that dies hands the robots back.
        ``-2147483648`` lifts it, once, and ends the refreshes."""
        self.request("min_priority value {}".format(value))
        self._min_priority = None if value == _I32_MIN else (value, now)

    def _min_priority_due(self):
        value, asked = self._min_priority
        # Before the hub has said its lease, as often as a silent channel is
        # asked for again: a console need not subscribe to anything.
        every = self.refresh_interval() if self.lease_ms is not None else min(self.refresh, self.resubscribe_after)
        return asked + every

    def poll_timeout(self):
        """When :meth:`handle_timeout` next has work, or None when nothing is held."""
        due = []
        if self._subs:
            refresh = self.refresh_interval()
            due.append(min(s.due(refresh, self.resubscribe_after) for s in self._subs))
        if self._min_priority is not None:
            due.append(self._min_priority_due())
        return min(due) if due else None

    def handle_timeout(self, now):
        """Queues a subscribe request for every subscription due by ``now``,
        and the raised minimum priority when its refresh is due."""
        self._clock = max(self._clock, now)
        refresh = self.refresh_interval()
        due = [s for s in self._subs if s.due(refresh, self.resubscribe_after) <= now]
        self._request_subscriptions(now, due)
        if self._min_priority is not None and self._min_priority_due() <= now:
            self.set_min_priority(now, self._min_priority[0])

    def _request_subscriptions(self, now, subs):
        for s in subs:
            s.last_request = now
        # One control packet carries many subscriptions; split only to fit a
        # datagram with the cookie line and an authentication line.
        per_packet = (MAX_PACKET - 256) // (len("subscribe ch \n") + MAX_SUBJECT_LEN)
        for i in range(0, len(subs), per_packet):
            self.request(*("subscribe ch " + s.subject for s in subs[i : i + per_packet]))

    def poll_transmit(self):
        """The next datagram to send to the hub, or None."""
        return self._outbox.popleft() if self._outbox else None

    def note_data(self, now, packet):
        self.last_from_hub = now
        for s in self._subs:
            if s.subject in packet.subjects:
                s.last_data = now

    def handle_datagram(self, now, data):
        """Notes a datagram from the hub. Returns ``('packet', Packet)`` for
        published data, ``('lease', ms)``, ``('cookie', hex)`` or
        ``('status', Packet)`` for the hub's replies, ``('hub', Packet)`` for
        another packet on ``<hub>``. Raises ParseError for a datagram that does
        not parse.

        A new cookie queues every subscription again at once (take it from
        :meth:`poll_transmit`); the cookie already held queues nothing, so a
        hub (or a forger) repeating it cannot start an exchange that never ends.
        """
        self.last_from_hub = now
        self._clock = max(self._clock, now)
        packet = parse(data)
        if packet.is_control():
            first = packet.lines[0] if packet.lines else (None, {})
            if first[0] == "lease" and isinstance(first[1].get("ms"), int):
                # A forged `lease ms 0` must not set the client chattering.
                self.lease_ms = min(max(first[1]["ms"], MIN_LEASE_MS), 86_400_000)
                self.leases += 1
                return "lease", self.lease_ms
            if first[0] == "cookie":
                _, raw = _first_line_raw(packet)
                cookie = raw.get("v")
                if cookie is not None and _COOKIE.fullmatch(cookie):
                    self.cookies += 1
                    # Taken only in answer to something asked lately, and not
                    # twice within a quarter second: replies forged from the
                    # hub's address, alternating two cookies, could otherwise
                    # keep the client resending everything it holds.
                    asked = self._last_asked is not None and now - self._last_asked < _RESEND_WITHIN
                    too_soon = self._last_cookie is not None and now - self._last_cookie < _COOKIE_EVERY
                    if cookie != self.cookie and asked and not too_soon:
                        self.cookie = cookie
                        self._last_cookie = now
                        # One-off requests first: an unsubscribe followed by a
                        # subscribe to the same channel must end subscribed.
                        recent, self._recent = self._recent, []
                        for t, lines in recent:
                            if now - t < _RESEND_WITHIN:
                                self.request(*lines)
                        self._request_subscriptions(now, self._subs)
                    return "cookie", cookie
                return "hub", packet
            if first[0] == "status":
                # The report says the lease too: a console that subscribes to
                # nothing learns from it how often to refresh its minimum priority.
                lease = first[1].get("lease_ms")
                if isinstance(lease, int) and lease > 0:
                    self.lease_ms = lease
                return "status", packet
            return "hub", packet
        self.note_data(now, packet)
        return "packet", packet

    def hub_state(self, now):
        """``'unknown'``, ``'alive'`` or ``'unreachable'``, as the Rust ``HubState``."""
        since = self.started if self.last_from_hub is None else self.last_from_hub
        if now - since >= self.unreachable_after and self._subs:
            return "unreachable"
        return "unknown" if self.last_from_hub is None else "alive"


def _is_subscribe(line):
    return line.split(None, 1)[:1] == ["subscribe"]


# --------------------------------------------------------------------------- authentication


#: The longest key file read (a key is a few dozen bytes).
_MAX_KEY_FILE = 4096


def read_key(path):
    """The key in a file, as ``colony hub --key FILE`` reads it: the file's bytes
    with trailing whitespace (blank, tab, line ends, form feed) trimmed."""
    with open(path, "rb") as f:
        # Bounded, as colony's own reader: `/dev/zero` must not fill memory.
        key = f.read(_MAX_KEY_FILE + 1)
    if len(key) > _MAX_KEY_FILE:
        raise ValueError("key file {} is longer than {} bytes: is it a key?".format(path, _MAX_KEY_FILE))
    key = key.rstrip(b" \t\r\n\x0c")
    if not key:
        raise ValueError("key file {} is empty".format(path))
    return key


def _now_us():
    return time.time_ns() // 1000


class Signer:
    """Signs packets for a hub that checks them (``colony hub --key FILE``).

    Appends the line ``auth n N mac M``: N is a counter, microseconds since the
    UNIX epoch and strictly increasing (``max(last + 1, now)``), so the hub can
    refuse a replayed packet; M is the HMAC-SHA256 of every byte before it
    (through ``mac``), under ``key``, in 64 lowercase hex digits::

        Signer(b"secret").sign(b"@ <hub> 0\\nstatus\\n")
        # b'@ <hub> 0\\nstatus\\nauth n 1764037... mac 5f0c...\\n'

    ``clock`` gives the microseconds (for tests); the default is the system clock.
    """

    def __init__(self, key, clock=None):
        if isinstance(key, str):
            key = key.encode("utf-8")
        key = bytes(key)
        if not key:
            raise ValueError("an empty key authenticates nothing")
        self._key = key
        self._clock = _now_us if clock is None else clock
        #: The counter of the last packet signed.
        self.last = 0

    def sign(self, data):
        """``data`` (a valid packet) with its authentication line. Raises
        ParseError (``too_large``) when the line does not fit in a datagram."""
        n = max(self.last + 1, int(self._clock()))
        self.last = n
        data = bytes(data)
        if not data.endswith(b"\n"):
            data += b"\n"
        head = data + b"auth n %d mac " % n
        mac = hmac.new(self._key, head, hashlib.sha256).hexdigest().encode("ascii")
        out = head + mac + b"\n"
        if len(out) > MAX_PACKET:
            raise ParseError("too_large", 1, 1, len=len(out))
        return out


# --------------------------------------------------------------------------- seals

# Ed25519 (RFC 8032) from its math, so the client stays standard library only:
# the curve -x^2 + y^2 = 1 + d x^2 y^2 over GF(p), points in extended
# coordinates (X, Y, Z, T) with x = X/Z, y = Y/Z, x y = T/Z. CPython's
# integers are not constant time, so neither is this: fit for keys that name a
# process on a robot network, not for secrets an attacker can time closely.
_P = 2 ** 255 - 19
_L = 2 ** 252 + 27742317777372353535851937790883648493
_D = -121665 * pow(121666, _P - 2, _P) % _P
_SQRT_M1 = pow(2, (_P - 1) // 4, _P)
_IDENTITY = (0, 1, 1, 0)
_BASE_Y = 4 * pow(5, _P - 2, _P) % _P


def _pt_add(p, q):
    # The unified formula (RFC 8032 5.1.4): correct for doubling and the identity too.
    x1, y1, z1, t1 = p
    x2, y2, z2, t2 = q
    a = (y1 - x1) * (y2 - x2) % _P
    b = (y1 + x1) * (y2 + x2) % _P
    c = 2 * t1 * t2 * _D % _P
    d = 2 * z1 * z2 % _P
    e, f, g, h = b - a, d - c, d + c, b + a
    return (e * f % _P, g * h % _P, f * g % _P, e * h % _P)


def _pt_double(p):
    x1, y1, z1, _ = p
    a = x1 * x1 % _P
    b = y1 * y1 % _P
    c = 2 * z1 * z1 % _P
    h = a + b
    e = h - (x1 + y1) * (x1 + y1)
    g = a - b
    f = c + g
    return (e * f % _P, g * h % _P, f * g % _P, e * h % _P)


def _pt_mul(s, p):
    q = _IDENTITY
    while s:
        if s & 1:
            q = _pt_add(q, p)
        p = _pt_double(p)
        s >>= 1
    return q


def _pt_decode(b):
    """The point 32 bytes encode, or None. Strict: y must be below p (one
    encoding per point), and x = 0 must come with a clear sign bit."""
    y = int.from_bytes(b, "little")
    sign = y >> 255
    y &= (1 << 255) - 1
    if y >= _P:
        return None
    x2 = (y * y - 1) * pow(_D * y * y + 1, _P - 2, _P) % _P
    x = pow(x2, (_P + 3) // 8, _P)
    if (x * x - x2) % _P:
        x = x * _SQRT_M1 % _P
        if (x * x - x2) % _P:
            return None
    if x == 0 and sign:
        return None
    if x & 1 != sign:
        x = _P - x
    return (x, y, 1, x * y % _P)


def _pt_encode(p):
    x, y, z, _ = p
    zi = pow(z, _P - 2, _P)
    x, y = x * zi % _P, y * zi % _P
    return (y | (x & 1) << 255).to_bytes(32, "little")


def _pt_small_order(p):
    # The torsion subgroup has order 8: such a point times 8 is the identity.
    for _ in range(3):
        p = _pt_double(p)
    return p[0] % _P == 0 and (p[1] - p[2]) % _P == 0


_BASE = _pt_decode(_BASE_Y.to_bytes(32, "little"))
# 2^i B, filled on first use: a fixed-base product then costs additions only.
_BASE_POWERS = []


def _base_mul(s):
    if not _BASE_POWERS:
        p = _BASE
        for _ in range(256):
            _BASE_POWERS.append(p)
            p = _pt_double(p)
    q = _IDENTITY
    i = 0
    while s:
        if s & 1:
            q = _pt_add(q, _BASE_POWERS[i])
        s >>= 1
        i += 1
    return q


def _h_int(*parts):
    return int.from_bytes(hashlib.sha512(b"".join(parts)).digest(), "little")


def _expand_seed(seed):
    if not isinstance(seed, (bytes, bytearray)) or len(seed) != 32:
        raise ValueError("an Ed25519 seed is 32 bytes")
    h = hashlib.sha512(bytes(seed)).digest()
    a = int.from_bytes(h[:32], "little") & ((1 << 254) - 8) | (1 << 254)
    return a, h[32:]


def ed25519_public_key(seed):
    """The 32-byte public key of a 32-byte secret seed (RFC 8032 5.1.5)."""
    return _pt_encode(_base_mul(_expand_seed(seed)[0]))


def _sign(a, prefix, public, message):
    r = _h_int(prefix, message) % _L
    big_r = _pt_encode(_base_mul(r))
    s = (r + _h_int(big_r, public, message) % _L * a) % _L
    return big_r + s.to_bytes(32, "little")


def ed25519_sign(seed, message):
    """The 64-byte signature of ``message`` under a 32-byte seed (RFC 8032 5.1.6)."""
    a, prefix = _expand_seed(seed)
    return _sign(a, prefix, _pt_encode(_base_mul(a)), bytes(message))


def ed25519_verify(public, message, signature):
    """Whether ``signature`` is the signature of ``message`` under ``public``,
    checked as strictly as ed25519-dalek's ``verify_strict``: S below the
    group order (no malleable second signature), the key and R canonical
    encodings of points of more than small order (no key that verifies
    everything). Never raises on bad bytes."""
    try:
        public, message, signature = bytes(public), bytes(message), bytes(signature)
    except TypeError:
        return False
    if len(public) != 32 or len(signature) != 64:
        return False
    a = _pt_decode(public)
    r = _pt_decode(signature[:32])
    s = int.from_bytes(signature[32:], "little")
    if a is None or r is None or s >= _L or _pt_small_order(a) or _pt_small_order(r):
        return False
    k = _h_int(signature[:32], public, message) % _L
    minus_a = (-a[0] % _P, a[1], a[2], -a[3] % _P)
    # [S]B - [k]A must be R itself, encoded exactly as sent.
    return _pt_encode(_pt_add(_base_mul(s), _pt_mul(k, minus_a))) == signature[:32]


def fingerprint(key):
    """A public key's short name, as the Rust ``PublicKey::fingerprint``: the
    first 8 bytes of its SHA-256, big-endian (a provider's id, in 16 hex digits)."""
    return int.from_bytes(hashlib.sha256(bytes(key)).digest()[:8], "big")


class SealError(ValueError):
    """Why a seal was refused. ``kind`` is ``missing`` (the last line is no
    seal line), ``malformed`` (not ``seal n N key <64 hex> sig <128 hex>``),
    ``bad_key`` (no Ed25519 public key) or ``bad_signature``."""

    def __init__(self, kind, message):
        super().__init__(message)
        self.kind = kind


_SEAL_HEAD = b"seal n "
_SEAL_KEY = b" key "
_SEAL_SIG = b" sig "
_LOWER_HEX = re.compile(rb"[0-9a-f]*")
_U64_MAX = 2 ** 64 - 1


class Sealed(tuple):
    """What :func:`open_seal` returns: ``(body, key, n)``, also by name."""

    __slots__ = ()

    def __new__(cls, body, key, n):
        return tuple.__new__(cls, (body, key, n))

    body = property(lambda self: self[0], doc="the packet as it was before it was sealed")
    key = property(lambda self: self[1], doc="the 32-byte public key that sealed it")
    n = property(lambda self: self[2], doc="its count among the packets that key sealed")


def _split_seal(data):
    """``(start, n, key, sig, sig_at)`` of a well-formed seal line at the end
    of ``data``, read exactly as the Rust ``seal::split_seal`` reads it."""
    missing = SealError("missing", "the packet is not sealed")
    malformed = SealError("malformed", "the `seal` line is not `seal n N key <64 hex digits> sig <128 hex digits>`")
    text = data[:-1] if data.endswith(b"\n") else data
    sig_at = len(text) - 128
    key_at = sig_at - len(_SEAL_SIG) - 64
    n_end = key_at - len(_SEAL_KEY)
    if n_end < 0 or text[sig_at - len(_SEAL_SIG):sig_at] != _SEAL_SIG or text[n_end:key_at] != _SEAL_KEY:
        raise missing
    before = text[:n_end]
    digits = len(before) - len(before.rstrip(b"0123456789"))
    n_at = n_end - digits
    start = n_at - len(_SEAL_HEAD)
    if start < 0 or text[start:n_at] != _SEAL_HEAD or (start > 0 and text[start - 1] != 0x0A):
        raise missing
    if digits == 0 or digits > 20 or (digits > 1 and text[n_at] == 0x30):
        raise malformed
    n = int(text[n_at:n_end])
    key_hex, sig_hex = text[key_at:sig_at - len(_SEAL_SIG)], text[sig_at:]
    if n > _U64_MAX or not _LOWER_HEX.fullmatch(key_hex) or not _LOWER_HEX.fullmatch(sig_hex):
        raise malformed
    return start, n, bytes.fromhex(key_hex.decode("ascii")), bytes.fromhex(sig_hex.decode("ascii")), sig_at


def _as_bytes(data):
    if isinstance(data, str):
        return data.encode("utf-8")
    return bytes(memoryview(data))


def open_seal(data):
    """Checks a packet's seal; returns :class:`Sealed` ``(body, key, n)``: the
    packet without its seal line, the 32 bytes of the key that sealed it, and
    its count. Raises :class:`SealError` (never anything else) for any bytes
    that are no packet sealed as ``colony_wire::seal`` seals them."""
    data = _as_bytes(data)
    start, n, key, sig, sig_at = _split_seal(data)
    point = _pt_decode(key)
    if point is None:
        raise SealError("bad_key", "the seal's key is not an Ed25519 public key")
    if not ed25519_verify(key, data[:sig_at], sig):
        raise SealError("bad_signature", "the seal's signature does not match the packet")
    return Sealed(data[:start], key, n)


def strip_seal(data):
    """The packet without a trailing seal line, unchecked (for showing what a packet says)."""
    data = _as_bytes(data)
    try:
        return data[:_split_seal(data)[0]]
    except SealError:
        return data


class Identity:
    """A process's Ed25519 key and the count of packets it sealed, as the Rust
    ``seal::Identity``. A new one draws its seed from the operating system;
    give ``seed`` (32 bytes) only for runs that must repeat exactly.

    :meth:`seal` appends ``seal n N key K sig S``: N counts the packets this
    key sealed (1, 2, ...), K is :attr:`key` in 64 lowercase hex digits, S the
    signature of every byte before it, so a receiver knows which process
    wrote a packet and can refuse a copy sent again."""

    def __init__(self, seed=None):
        seed = os.urandom(32) if seed is None else bytes(seed)
        self._a, self._prefix = _expand_seed(seed)
        #: The 32-byte public key that names this process.
        self.key = _pt_encode(_base_mul(self._a))
        #: The count of packets sealed so far.
        self.n = 0

    @property
    def key_hex(self):
        return self.key.hex()

    @property
    def fingerprint(self):
        return fingerprint(self.key)

    def __repr__(self):
        # The secret never reaches a log.
        return "Identity({})".format(self.key_hex)

    def seal(self, packet):
        """``packet`` (a whole packet) with its seal line. Raises ParseError
        (``too_large``) when the seal does not fit in a datagram."""
        data = _as_bytes(packet)
        if data and not data.endswith(b"\n"):
            data += b"\n"
        if len(data) + 210 + len(str(self.n + 1)) > MAX_PACKET:
            raise ParseError("too_large", 1, 1, len=len(data) + 210 + len(str(self.n + 1)))
        self.n += 1
        head = data + b"seal n %d key %s sig " % (self.n, self.key_hex.encode("ascii"))
        return head + _sign(self._a, self._prefix, self.key, head).hex().encode("ascii") + b"\n"


# --------------------------------------------------------------------------- client


def _hub_address(hub):
    if hub is None:
        hub = os.environ.get("COLONY_HUB") or DEFAULT_HUB
    if isinstance(hub, str):
        text = hub.strip()
        if text.startswith("["):
            host, sep, port = text[1:].partition("]:")
        else:
            host, sep, port = text.rpartition(":")
        if not sep or not host or not port.isdigit():
            raise ValueError("hub address {!r}: expected HOST:PORT".format(hub))
        hub = (host, int(port))
    host, port = hub[0], int(hub[1])
    infos = socket.getaddrinfo(host, port, 0, socket.SOCK_DGRAM)
    if not infos:
        raise OSError("hub address {!r}: no address found".format(hub))
    family, _, _, _, addr = infos[0]
    return family, addr


# Datagrams (and errors) one receive call takes in before it returns as if
# nothing were waiting: a flood of junk, replies or forged ICMP errors from the
# hub's address must not hold the application away from its lease refreshes.
# The socket stays readable. The Rust client's RECV_BUDGET.
_RECV_BUDGET = 256
# What a connected UDP socket reports for one datagram (an ICMP error that came
# back: refused, unreachable, prohibited, too big; a full buffer) and not for
# the socket: the next datagram may well pass. The same list as the Rust and C
# clients' (colony_sys::udp::is_transient, transient() in colony_client.c).
_TRANSIENT = frozenset(
    getattr(errno, name)
    for name in (
        "ECONNREFUSED", "EHOSTUNREACH", "ENETUNREACH", "EHOSTDOWN", "ENETDOWN", "ENONET", "EACCES",
        "EMSGSIZE", "EPROTO", "ENOPROTOOPT", "ENOBUFS", "EAGAIN", "EINTR",
    )
    if hasattr(errno, name)
)


class Client:
    """A hub client on a non-blocking UDP socket connected to the hub.

    It never blocks (except :meth:`status`, which waits at most its timeout),
    never starts a thread and never owns the loop::

        c = Client(("127.0.0.1", 7400))
        c.subscribe("vision_out")
        while True:
            d = c.next_deadline()
            select.select([c], [], [], None if d is None else max(0.0, d - time.monotonic()))
            c.poll()
            while True:
                p = c.recv()
                if p is None:
                    break
                print(p.line("ball"))

    ``hub`` is ``(host, port)`` or ``"host:port"``; None means the environment
    variable ``COLONY_HUB``, else ``127.0.0.1:7400``.

    ``key`` (bytes or str, e.g. from :func:`read_key`): the key of a hub
    started with ``--key FILE``; every packet the client sends is then signed
    with it (see :class:`Signer`), requests and published packets alike.

    The hub's lease and cookie are followed without the application seeing
    them (see :class:`Session`). A datagram that does not parse is skipped by
    :meth:`recv` and counted in :attr:`malformed`, so one bad publisher cannot
    stop a subscriber.
    """

    def __init__(self, hub=None, refresh=3.0, resubscribe_after=1.0, unreachable_after=10.0, key=None):
        signer = None if key is None else Signer(key)
        family, addr = _hub_address(hub)
        self.hub = addr
        sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            try:
                loopback = ipaddress.ip_address(addr[0]).is_loopback
            except ValueError:
                loopback = False
            if loopback:
                # Stay on loopback when the hub is local, so nothing else can reach us.
                sock.bind(("::1", 0) if family == socket.AF_INET6 else ("127.0.0.1", 0))
            sock.connect(addr)
            sock.setblocking(False)
        except BaseException:
            sock.close()
            raise
        self._sock = sock
        self._signer = signer
        self.session = Session(
            time.monotonic(),
            refresh=refresh,
            resubscribe_after=resubscribe_after,
            unreachable_after=unreachable_after,
        )
        # Data packets that arrived while status() waited, for recv().
        self._pending = deque()
        #: Datagrams received that did not parse.
        self.malformed = 0
        #: Send and receive calls that failed for one datagram and were gone
        #: past (the hub down, its network unreachable, ...): datagrams lost.
        self.network_errors = 0

    # -- plumbing

    def fileno(self):
        """The socket's descriptor, for select/poll/epoll/selectors."""
        return self._sock.fileno()

    @property
    def local_addr(self):
        return self._sock.getsockname()

    @property
    def lease_ms(self):
        """The hub's lease in milliseconds, once a lease reply arrived (else None)."""
        return self.session.lease_ms

    def close(self):
        self._sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _send(self, datagram):
        if self._signer is not None:
            datagram = self._signer.sign(datagram)
        try:
            self._sock.send(datagram)
        except OSError as e:
            # A full buffer, a hub that is down (refused) or a network that is
            # briefly unreachable loses this one datagram, counted; the session
            # recovers. A robot's program must not die of a Wi-Fi gap.
            if e.errno not in _TRANSIENT:
                raise
            self.network_errors += 1
        return datagram

    def _flush(self):
        while True:
            d = self.session.poll_transmit()
            if d is None:
                return
            self._send(d)

    # -- subscriptions

    def subscribe(self, subject):
        """Subscribes to a channel (or to one subject of a subject set) and asks the hub now."""
        (subject,) = _subject_list([subject])
        if subject == HUB_SUBJECT:
            raise ValueError("`hub` is reserved for requests to the hub itself")
        now = time.monotonic()
        self.session.subscribe(now, subject)
        self.poll(now)

    def unsubscribe(self, subject):
        (subject,) = _subject_list([subject])
        self.session.unsubscribe(subject)
        self._flush()

    def unsubscribe_all(self):
        self.session.unsubscribe_all()
        self._flush()

    def subscriptions(self):
        return self.session.subscriptions()

    def request(self, *lines):
        """Sends control request lines to the hub, e.g. ``request("min_priority value 5")``."""
        self.session.request(*lines)
        self._flush()

    def set_min_priority(self, value):
        """Tells the hub to drop every published packet below this priority.

        The hub takes it only from a console (``colony hub --console`` naming
        this address, or a client with the hub's ``key``), and a raised minimum
        lapses after the hub's lease unless refreshed: the client refreshes it
        (keep calling :meth:`poll` at :meth:`next_deadline`) until it is set to
        ``-2147483648``, which lifts it at once. A console that stops hands the
        robots back."""
        if isinstance(value, bool) or not isinstance(value, int) or not _I32_MIN <= value <= _I32_MAX:
            raise ValueError("the minimum priority is a 32-bit int")
        self.session.set_min_priority(time.monotonic(), value)
        self._flush()

    # -- publishing

    def publish(self, subjects, priority=0, lines=()):
        """Builds (see :func:`build`) and sends a packet; returns the bytes sent
        (with the authentication line when the client has a key)."""
        names = _subject_list(subjects)
        if HUB_SUBJECT in names:
            raise ValueError("`hub` is reserved for requests to the hub; use publish_raw")
        data = build(names, priority, lines)
        return self._send(data)

    def publish_raw(self, data):
        """Sends a packet written by hand, checked first (a bad one raises ParseError
        here rather than being dropped silently by the hub)."""
        if isinstance(data, str):
            data = data.encode("utf-8")
        data = bytes(data)
        parse(data)
        return self._send(data)

    # -- the loop

    def poll(self, now=None):
        """Sends whatever is due by ``now`` (monotonic seconds): refreshes and resubscriptions."""
        now = time.monotonic() if now is None else now
        self.session.handle_timeout(now)
        self._flush()

    def next_deadline(self):
        """When :meth:`poll` next has work (``time.monotonic()`` seconds), or None."""
        return self.session.poll_timeout()

    def timeout(self, now=None):
        """Seconds until :meth:`next_deadline` (0 if past), or None: a select() timeout."""
        d = self.next_deadline()
        if d is None:
            return None
        now = time.monotonic() if now is None else now
        return max(0.0, d - now)

    def _recv_one(self, budget):
        """The next datagram handled by the session: (kind, value), or None when
        nothing is waiting or ``budget`` (a one-item list, one spent per
        datagram or error taken in) is spent."""
        while True:
            if budget[0] <= 0:
                return None
            budget[0] -= 1
            try:
                data = self._sock.recv(MAX_PACKET + 1)
            except BlockingIOError:
                return None
            except InterruptedError:
                continue
            except OSError as e:
                # An ICMP error for a datagram we sent (the hub's port closed,
                # its host or network unreachable) is reported once, here,
                # before queued data; the session resubscribes once the hub
                # answers again.
                if e.errno not in _TRANSIENT:
                    raise
                self.network_errors += 1
                continue
            try:
                got = self.session.handle_datagram(time.monotonic(), data)
            except ParseError:
                # One bad datagram (a publisher's, or a forger's) is skipped,
                # never raised: every subscriber on the channel would die of it.
                self.malformed += 1
                continue
            # A cookie reply has queued every subscription again: send them now.
            self._flush()
            return got

    def recv(self):
        """The next packet published on a subscribed channel, or None when none
        is waiting. The hub's replies are taken in along the way."""
        if self._pending:
            return self._pending.popleft()
        budget = [_RECV_BUDGET]
        while True:
            got = self._recv_one(budget)
            if got is None:
                return None
            kind, value = got
            if kind == "packet":
                return value

    def __iter__(self):
        """Every packet waiting now (does not block)."""
        while True:
            p = self.recv()
            if p is None:
                return
            yield p

    def hub_state(self, now=None):
        """``'unknown'`` (nothing heard yet), ``'alive'`` or ``'unreachable'``
        (silent for ``unreachable_after`` while we hold subscriptions)."""
        return self.session.hub_state(time.monotonic() if now is None else now)

    def hub_alive(self, now=None):
        """Whether the hub was heard from within ``unreachable_after`` seconds.

        A client with subscriptions hears the hub at least every few seconds
        (lease replies); a client that only publishes hears nothing until it
        asks, e.g. with :meth:`status`."""
        last = self.session.last_from_hub
        if last is None:
            return False
        now = time.monotonic() if now is None else now
        return now - last < self.session.unreachable_after

    # -- status

    def status(self, timeout=3.0, channel="colony-status"):
        """Asks the hub for its status; returns it as a dict::

            {"uptime_ms": int, "lease_ms": int, "min_priority": int,
             "client_count": int, "truncated": bool,
             "drops": {reason: count},
             "channels": [{"ch": str, "packets": int, "bytes": int}],
             "clients": [{"addr": "127.0.0.1:5000", "idle_ms": int,
                          "subs": {subject: ms_left}}]}

        The hub answers only a client that held a lease before it asked, so
        this subscribes first (to a subscription already held, else to
        ``channel``), waits for the lease reply and then asks, asking again
        every 0.3 s. It waits at most ``timeout`` seconds, then raises
        TimeoutError. Data packets arriving meanwhile are kept for :meth:`recv`.
        """
        deadline = time.monotonic() + timeout
        subs = self.subscriptions()
        if subs:
            return self._status_with_lease(subs[0], deadline, timeout, asked=False)
        # Only for this question: a client that subscribes to nothing holds no lease after it.
        self.subscribe(channel)
        try:
            return self._status_with_lease(channel, deadline, timeout, asked=True)
        finally:
            self.unsubscribe(channel)

    def _status_with_lease(self, subject, deadline, timeout, asked):
        leased = False
        # Ask at once, unless subscribe() just did; then again every 0.3 s
        # until answered, as either datagram may be lost.
        next_ask = time.monotonic() + (0.3 if asked else 0.0)
        while True:
            now = time.monotonic()
            if now >= deadline:
                break
            if now >= next_ask:
                if leased:
                    self.request("status")
                else:
                    self.request("subscribe ch " + subject)
                next_ask = now + 0.3
            select.select([self._sock], [], [], max(0.0, min(next_ask, deadline) - now))
            budget = [_RECV_BUDGET]
            while True:
                got = self._recv_one(budget)
                if got is None:
                    break
                kind, value = got
                if kind == "packet":
                    self._pending.append(value)
                elif kind == "lease" and not leased:
                    leased = True
                    self.request("status")
                    next_ask = time.monotonic() + 0.3
                elif kind == "status":
                    return parse_status(value)
            self.poll()
        raise TimeoutError(
            "no status from a hub at {}:{} within {:.1f} s (is `colony hub` running there?)".format(
                self.hub[0], self.hub[1], timeout
            )
        )


# --------------------------------------------------------------------------- request and reply

# Request and reply over publish/subscribe, as the Rust client's ``rpc``
# module writes it (crates/client/src/rpc/message.rs holds the one definition):
# a provider announces ``provider id P lease_ms L`` on ``svc.NAME`` every third
# of its lease, and at once (with ``nonce X``) when a caller asks ``who nonce
# X``; a call goes to one provider's inbox ``svc.NAME.P`` with ``call id N
# reply_to reply.C`` first; the provider says ``accepted id N from P`` to the
# caller's inbox ``reply.C`` as it takes the call, then answers there with
# ``reply id N from P`` (or ``refused id N from P text "why"``); a provider
# that stops says ``leaving id P``.
#
# Everything a provider says is sealed (:class:`Identity`), and its id P is
# the fingerprint of its key, so a caller believes a notice or an answer only
# from the key P names: nobody else can answer for a provider, end its calls
# or cut its lease. Calls and ``who`` stay unsealed: callers are anonymous.

#: What a service's channel name starts with.
SERVICE_PREFIX = "svc."
#: What a caller's inbox starts with (a call may name no other place to answer).
REPLY_PREFIX = "reply."
_ID = re.compile(r"[0-9a-f]{16}")
#: The longest service name: room for the prefix, a dot and a provider id.
MAX_SERVICE_LEN = MAX_SUBJECT_LEN - len(SERVICE_PREFIX) - 1 - 16
#: A caller with calls but no provider proven live asks who provides this often (seconds).
_ASK_EVERY = 0.25
#: How long a caller waits for a provider to accept a call, or for echoes of its `who`, by default (seconds).
ACK_WAIT = 0.25
#: A provider answers `who` from a bucket of this many, refilled at this many a second.
_WHO_BURST = 10
_WHO_RATE = 10.0
#: The longest provider lease believed (seconds): a forged announcement holds a place this long at most.
_LONGEST_LEASE = 60.0
#: The longest a call may wait (seconds).
_LONGEST_TIMEOUT = 86400.0
#: The most providers a caller keeps.
_MOST_PROVIDERS = 64
#: The most datagrams one poll takes in, so a flood leaves time for the timers.
_MOST_PER_POLL = 256
# Room an answer leaves for the longest seal line and the `auth` line a hub
# key adds, so a sealed answer still fits one datagram (as the Rust provider).
_SEALED_ROOM = (7 + 20 + 5 + 64 + 5 + 128 + 1) + (7 + 20 + 5 + 64 + 1)


def _fresh_id():
    return "{:016x}".format(random.SystemRandom().getrandbits(64))


def _service_channel(name):
    # A name ending in `.` and an id would make this service's channel another's provider inbox.
    looks_like_inbox = isinstance(name, str) and bool(_ID.fullmatch(name.rpartition(".")[2])) and "." in name
    if (not isinstance(name, str) or not 0 < len(name) <= MAX_SERVICE_LEN
            or not is_subject(SERVICE_PREFIX + name) or looks_like_inbox):
        raise ValueError(
            "{!r} cannot name a service: use letters, digits and `_-.:/`, 1 to {} bytes".format(
                name, MAX_SERVICE_LEN
            )
        )
    return SERVICE_PREFIX + name


def _body_lines(packet):
    """The lines after the first, as written (a call's or an answer's own lines)."""
    raw = (l.strip(" \t\r") for l in packet.text[packet._body:].split("\n"))
    return [l for l in raw if l][1:]


def _rpc_packet(subject, priority, first, lines):
    text = "@ <{}> {}\n{}\n{}".format(subject, priority, first, "".join(l + "\n" for l in lines))
    data = text.encode("utf-8")
    parse(data)
    return data


def _open_from(packet, name):
    """``(what it sealed, parsed; the id it names in ``name``; the seal's
    count)`` when the packet is sealed by the key whose fingerprint is that
    id, else None. The key is matched to the id before the (costlier)
    signature is checked."""
    try:
        data = packet.text.encode("utf-8")
        key = _split_seal(data)[2]
        pid = _first_line_raw(packet)[1].get(name)
        if pid is None or not _ID.fullmatch(pid) or int(pid, 16) != fingerprint(key):
            return None
        body, _, n = open_seal(data)
        inner = parse(body)
        # What was sealed must name the same id (not merely what follows it).
        if _first_line_raw(inner)[1].get(name) != pid or inner.subjects != packet.subjects:
            return None
        return inner, pid, n
    except (SealError, ParseError, ValueError):
        return None


class CallError(Exception):
    """Why a call ended without an answer. ``kind`` is one of ``no_provider``,
    ``timeout``, ``provider_left``, ``provider_lapsed`` (silent past its lease),
    ``refused`` or ``unsendable``; ``provider`` the provider's id, if one was chosen."""

    def __init__(self, kind, message, provider=None):
        super().__init__(message)
        self.kind = kind
        self.provider = provider


class Answer:
    """A provider's answer: the call's ``id``, the ``provider``'s id, and the
    answer's ``lines`` as written (the ``reply`` line left out)."""

    __slots__ = ("id", "provider", "lines")

    def __init__(self, id, provider, lines):
        self.id = id
        self.provider = provider
        self.lines = lines

    def __repr__(self):
        return "Answer(id={!r}, provider={!r}, lines={!r})".format(self.id, self.provider, self.lines)


class Caller:
    """One caller of one service, sans I/O, like the Rust ``rpc::Caller``.

    Subscribe a client to :meth:`subjects`, hand every packet from them to
    :meth:`handle_packet`, call :meth:`handle_timeout` at :meth:`poll_timeout`,
    publish what :meth:`poll_transmit` gives, and read :meth:`poll_outcome`.

    Calls go to providers proven live first (they echoed this caller's latest
    ``who nonce``, or accepted one of its calls); with none, the caller asks
    ``who`` and waits up to ``ack_wait`` for an echo before trying providers
    only announced. A provider that neither accepts a call nor answers it
    within ``ack_wait`` (at most a quarter of the time left to the call) is
    marked unresponsive, tried last from then on, and the call goes to the
    next provider. Once accepted, a call is never sent elsewhere (the
    provider may have acted on it): it ends exactly once, with that provider's
    answer or a :class:`CallError`. Only what a provider sealed with the key
    its id names is believed; the rest is counted in :attr:`forged`.
    """

    def __init__(self, service, caller_id=None, ack_wait=ACK_WAIT):
        self.channel = _service_channel(service)
        self.service = service
        self.id = caller_id or _fresh_id()
        if not _ID.fullmatch(self.id):
            raise ValueError("an id is 16 lowercase hex digits")
        if not (isinstance(ack_wait, (int, float)) and 0 < ack_wait <= _LONGEST_LEASE):
            raise ValueError("an ack wait is a number of seconds, above 0 and at most 60")
        self.ack_wait = float(ack_wait)
        self.inbox = REPLY_PREFIX + self.id
        # id -> {"lease", "seen", "expires", "left", "proven", "unresponsive"};
        # expires is never brought forward, so no stale or copied
        # announcement can cut a lease short.
        self._providers = {}
        self._order = []
        self._turn = 0
        # id -> {lines, priority, started, deadline, sent_to, ack_by, accepted, late, tried, who_until}
        self._calls = {}
        self._next = random.SystemRandom().getrandbits(48)
        self._outbox = deque()
        self._outcomes = deque()
        self._last_asked = None
        self._nonce = None
        # Whether a call waits with no provider to try: then `who` is asked again and again.
        self._asking = False
        #: Answers that matched no call in flight (late or repeated) or came from a provider the call is not with.
        self.strays = 0
        #: Notices and answers not sealed by the provider they name.
        self.forged = 0

    def subjects(self):
        """The caller's inbox, then the service's channel: the inbox is asked
        for before any provider can be heard of."""
        return [self.inbox, self.channel]

    def providers(self):
        """The providers new calls may go to, in the order they are tried
        (proven live first, unresponsive last)."""
        live = [p for p in self._order if not self._providers[p]["left"]]
        return sorted(live, key=self._rank)

    @property
    def in_flight(self):
        return len(self._calls)

    def call(self, now, lines, timeout=5.0, priority=0):
        """Starts a call with these lines (packet lines as written); returns its id.
        Raises ParseError at once if the lines do not make a packet."""
        lines = [str(l) for l in lines]
        if not (isinstance(timeout, (int, float)) and 0 < timeout <= _LONGEST_TIMEOUT):
            raise ValueError("a call's timeout is from 0 to 86400 seconds")
        call_id = "{:016x}".format(self._next)
        self._next = (self._next + 1) % (1 << 64)
        # Checked with an inbox as long as any provider's.
        _rpc_packet(self.channel + "." + "0" * 16, priority,
                    "call id {} reply_to {}".format(call_id, self.inbox), lines)
        self._calls[call_id] = {"lines": lines, "priority": priority, "started": now,
                                "deadline": now + timeout, "sent_to": None, "ack_by": None,
                                "accepted": False, "late": False, "tried": set(), "who_until": None}
        self._dispatch(now)
        return call_id

    def handle_packet(self, now, packet):
        if len(packet.subjects) != 1 or not packet.lines or packet.text is None:
            return
        label, raw = _first_line_raw(packet)
        if packet.subjects[0] == self.channel:
            if label in ("provider", "leaving"):
                self._on_notice(now, packet, label)
        elif packet.subjects[0] == self.inbox:
            if label not in ("reply", "refused", "accepted"):
                self.strays += 1
                return
            call = self._calls.get(raw.get("id"))
            frm = raw.get("from")
            # Only a provider the call was sent to may take or end it, and once
            # one took it, only that one; the rest is not worth a signature check.
            if call is None or frm not in call["tried"] or (call["accepted"] and frm != call["sent_to"]):
                self.strays += 1
                return
            opened = _open_from(packet, "from")
            if opened is None:
                self.forged += 1
                return
            self._on_answer(now, opened[0], label, raw["id"], opened[1])

    def _on_notice(self, now, packet, label):
        opened = _open_from(packet, "id")
        if opened is None:
            self.forged += 1
            return
        inner, pid, n = opened
        known = self._providers.get(pid)
        if known is not None:
            # A notice recorded and sent again must not keep a dead provider alive.
            if n <= known["n"]:
                self.forged += 1
                return
            known["n"] = n
        if label == "leaving":
            if known is not None:
                self._leaving(now, pid)
            return
        fields = inner.lines[0][1]
        ms = fields.get("lease_ms")
        if isinstance(ms, bool) or not isinstance(ms, int) or ms < 0:
            self.forged += 1
            return
        nonce = _first_line_raw(inner)[1].get("nonce")
        echoed = nonce is not None and nonce == self._nonce
        self._note_provider(now, pid, min(max(ms, MIN_LEASE_MS) / 1000.0, _LONGEST_LEASE), echoed, n)

    def _on_answer(self, now, inner, label, call_id, frm):
        call = self._calls[call_id]
        known = self._providers.get(frm)
        if known is not None:
            # Taking or answering a call is as good a sign of life as an announcement.
            known.update(seen=now, expires=max(known["expires"], now + known["lease"]),
                         proven=True, unresponsive=False)
        if label == "accepted":
            # Taken (perhaps by a provider passed over, late): it goes nowhere else.
            call.update(accepted=True, ack_by=None, sent_to=frm, late=False)
            return
        if label == "refused":
            # A bare reason as written, a quoted one unescaped; a group is no reason.
            why = _first_line_raw(inner)[1].get("text")
            if why is None:
                why = inner.lines[0][1].get("text")
                if not isinstance(why, str):
                    self.strays += 1
                    return
            result = CallError("refused", "provider {} refused the call: {}".format(frm, why), frm)
        else:
            result = Answer(call_id, frm, _body_lines(inner))
        del self._calls[call_id]
        self._outcomes.append((call_id, result))
        # A call waiting for a provider may go to the one proven just now.
        self._dispatch(now)

    def handle_timeout(self, now):
        for pid in [p for p, k in self._providers.items() if k["expires"] <= now]:
            self._drop(pid, now)
        for call_id in [c for c, call in self._calls.items() if call["deadline"] <= now]:
            call = self._calls.pop(call_id)
            waited = now - call["started"]
            if call["sent_to"] is None:
                err = CallError("no_provider", "no provider of the service answered within {:.1f} s "
                                "(is one running on this hub?)".format(waited))
            else:
                err = CallError("timeout", "provider {} did not answer within {:.1f} s".format(
                    call["sent_to"], waited), call["sent_to"])
            self._outcomes.append((call_id, err))
        self._dispatch(now)

    def poll_timeout(self):
        times = [c["deadline"] for c in self._calls.values()]
        times += [c["ack_by"] for c in self._calls.values() if c["ack_by"] is not None]
        times += [c["who_until"] for c in self._calls.values()
                  if c["who_until"] is not None and not c["accepted"]]
        times += [k["expires"] for k in self._providers.values()]
        if self._asking and self._last_asked is not None:
            times.append(self._last_asked + _ASK_EVERY)
        return min(times) if times else None

    def poll_transmit(self):
        return self._outbox.popleft() if self._outbox else None

    def poll_outcome(self):
        """``(call_id, Answer or CallError)`` for the next call that ended, or None."""
        return self._outcomes.popleft() if self._outcomes else None

    def _rank(self, pid):
        k = self._providers[pid]
        return 2 if k["unresponsive"] else 0 if k["proven"] else 1

    def _ask(self, now):
        if self._last_asked is None or now >= self._last_asked + _ASK_EVERY:
            self._last_asked = now
            self._nonce = _fresh_id()
            self._outbox.append(_rpc_packet(self.channel, 0, "who nonce " + self._nonce, ()))

    def _note_provider(self, now, pid, lease, echoed, n):
        known = self._providers.get(pid)
        if known is not None:
            known.update(lease=lease, seen=now, expires=max(known["expires"], now + lease), left=False)
        else:
            if len(self._providers) >= _MOST_PROVIDERS:
                # Room is made only by one that would lapse before this one.
                soonest = min(self._providers, key=lambda p: self._providers[p]["expires"])
                if self._providers[soonest]["expires"] >= now + lease:
                    return
                self._drop(soonest, now)
            self._order.append(pid)
            known = self._providers[pid] = {"lease": lease, "seen": now, "expires": now + lease, "n": n,
                                             "left": False, "proven": False, "unresponsive": False}
        # An echo proves the process lives, not that it takes calls: one that
        # let a call go unaccepted stays last until it accepts one.
        if echoed and not known["unresponsive"]:
            known["proven"] = True
        self._dispatch(now)

    def _dispatch(self, now):
        self._asking = False
        live = [p for p in self._order
                if self._providers[p]["expires"] > now and not self._providers[p]["left"]]
        for call_id, call in self._calls.items():
            if call["accepted"]:
                continue
            if call["sent_to"] is not None and not call["late"]:
                if now < call["ack_by"]:
                    continue
                # Neither accepted nor answered in time: tried last from now on,
                # and the call looks for another provider until one takes it.
                silent = self._providers.get(call["sent_to"])
                if silent is not None:
                    silent.update(unresponsive=True, proven=False)
                call.update(ack_by=None, late=True)
            untried = sorted((p for p in live if p not in call["tried"]), key=self._rank)
            if not untried:
                # Nobody new to try: a call already sent stays where it is.
                call["who_until"] = None
                if call["sent_to"] is None:
                    self._asking = True
                    self._ask(now)
                continue
            if self._rank(untried[0]) != 0:
                # No provider proven live: ask, and give the echoes time to come.
                if call["who_until"] is None:
                    self._ask(now)
                    left = call["deadline"] - now
                    call["who_until"] = self._last_asked + min(self.ack_wait, left / 4.0)
                if now < call["who_until"]:
                    continue
            best = [p for p in untried if self._rank(p) == self._rank(untried[0])]
            to = best[self._turn % len(best)]
            self._turn += 1
            first = "call id {} reply_to {}".format(call_id, self.inbox)
            self._outbox.append(_rpc_packet(self.channel + "." + to, call["priority"], first, call["lines"]))
            call.update(sent_to=to, ack_by=now + min(self.ack_wait, (call["deadline"] - now) / 4.0),
                        who_until=None, late=False)
            call["tried"].add(to)

    def _leaving(self, now, pid):
        # It takes no new calls, and those it never took go elsewhere now; the
        # ones it accepted may still be answered, so they end with its lease.
        self._providers[pid]["left"] = True
        for call in self._calls.values():
            if call["sent_to"] == pid and not call["accepted"] and not call["late"]:
                call["ack_by"] = now
        self._dispatch(now)

    def _drop(self, pid, now):
        gone = self._providers.pop(pid, None)
        if gone is None:
            return
        self._order.remove(pid)
        for call_id in [c for c, call in self._calls.items() if call["sent_to"] == pid]:
            del self._calls[call_id]
            if gone["left"]:
                err = CallError("provider_left", "provider {} stopped before answering".format(pid), pid)
            else:
                err = CallError("provider_lapsed", "provider {} fell silent for {:.1f} s, past its {:.1f} s "
                                "lease, before answering".format(pid, now - gone["seen"], gone["lease"]), pid)
            self._outcomes.append((call_id, err))


class Call:
    """A call taken by a :class:`Provider`: its ``id``, the caller's ``reply_to``
    inbox, its ``priority``, its ``lines`` as written and the whole ``packet``."""

    __slots__ = ("id", "reply_to", "priority", "lines", "packet")

    def __init__(self, id, reply_to, priority, lines, packet):
        self.id = id
        self.reply_to = reply_to
        self.priority = priority
        self.lines = lines
        self.packet = packet


class Provider:
    """One provider of one service, sans I/O, like the Rust ``rpc::Provider``.

    Its id is the fingerprint of its key (``identity``, a new
    :class:`Identity` unless given), and it seals everything it says. It
    announces itself when made and every third of its ``lease`` (seconds),
    and answers each ``who`` at once (``who nonce X`` with ``nonce X``), up to
    10 a second (a burst of 10). :meth:`handle_packet` returns each call,
    having queued ``accepted`` for it: publish what :meth:`poll_transmit`
    gives before running the call, then :meth:`answer` or :meth:`refuse` it."""

    def __init__(self, service, now, lease=3.0, identity=None):
        self.channel = _service_channel(service)
        if identity is None:
            identity = Identity()
        if not isinstance(identity, Identity):
            raise TypeError("a provider's identity is an Identity")
        self.identity = identity
        self.id = "{:016x}".format(identity.fingerprint)
        if not (isinstance(lease, (int, float)) and lease == lease):
            raise ValueError("a lease is a number of seconds")
        self.lease = min(max(float(lease), MIN_LEASE_MS / 1000.0), _LONGEST_LEASE)
        self.inbox = self.channel + "." + self.id
        # Packets are sealed as they leave, so their counts rise in the order sent.
        self._outbox = deque()
        # The announcement (or farewell) not yet sent: one at most.
        self._notice = None
        self._bucket = float(_WHO_BURST)
        self._bucket_at = now
        #: Calls answered or refused.
        self.served = 0
        self._announce(now)

    def subjects(self):
        return [self.channel, self.inbox]

    def _announcement(self, nonce=None):
        first = "provider id {} lease_ms {}".format(self.id, int(self.lease * 1000))
        if nonce is not None:
            first += " nonce " + nonce
        return _rpc_packet(self.channel, 0, first, ())

    def _announce(self, now):
        self._last_announced = now
        self._notice = self._announcement()

    def handle_packet(self, now, packet):
        """A :class:`Call` for this provider, or None."""
        if len(packet.subjects) != 1 or not packet.lines:
            return None
        label, raw = _first_line_raw(packet)
        if packet.subjects[0] == self.channel:
            nonce = raw.get("nonce")
            # A nonce is 16 bare hex digits; a `who` with any other is answered by no echo.
            given = "nonce" in packet.lines[0][1]
            if label == "who" and (not given or (nonce and _ID.fullmatch(nonce))) and self._take_token(now):
                self._outbox.append(self._announcement(nonce))
                self._last_announced = now
            return None
        if packet.subjects[0] != self.inbox or label != "call":
            return None
        call_id, reply_to = raw.get("id"), raw.get("reply_to")
        if not (call_id and _ID.fullmatch(call_id) and reply_to and reply_to.startswith(REPLY_PREFIX)
                and is_subject(reply_to)):
            return None
        first = "accepted id {} from {}".format(call_id, self.id)
        self._outbox.append(_rpc_packet(reply_to, packet.priority, first, ()))
        return Call(call_id, reply_to, packet.priority, _body_lines(packet), packet)

    def _take_token(self, now):
        self._bucket = min(float(_WHO_BURST), self._bucket + max(0.0, now - self._bucket_at) * _WHO_RATE)
        self._bucket_at = now
        if self._bucket < 1.0:
            return False
        self._bucket -= 1.0
        return True

    def answer(self, call, lines):
        """Answers with these lines; raises ParseError if they do not make a packet."""
        first = "reply id {} from {}".format(call.id, self.id)
        packet = _rpc_packet(call.reply_to, call.priority, first, [str(l) for l in lines])
        if len(packet) + _SEALED_ROOM > MAX_PACKET:
            raise ParseError("too_large", 1, 1, len=len(packet) + _SEALED_ROOM)
        self._outbox.append(packet)
        self.served += 1

    def refuse(self, call, why):
        # What no packet can carry (lone surrogates, raw control characters) becomes `?`.
        why = _UNWRITABLE.sub("?", str(why)[:1024])
        first = "refused id {} from {} text {}".format(call.id, self.id, _quote(why))
        self._outbox.append(_rpc_packet(call.reply_to, call.priority, first, ()))
        self.served += 1

    def handle_timeout(self, now):
        if now >= self.poll_timeout():
            self._announce(now)

    def poll_timeout(self):
        return self._last_announced + self.lease / 3.0

    def leave(self):
        """Says the provider is stopping: callers send it no new calls."""
        self._notice = _rpc_packet(self.channel, 0, "leaving id " + self.id, ())

    def poll_transmit(self):
        if self._notice is not None:
            packet, self._notice = self._notice, None
        elif self._outbox:
            packet = self._outbox.popleft()
        else:
            return None
        return self.identity.seal(packet)


def _earliest(*times):
    times = [t for t in times if t is not None]
    return min(times) if times else None


class _OnClient:
    """A caller or provider on a :class:`Client` of its own: its descriptor,
    closing, and ``with``."""

    def _open(self, hub, subjects, client_args):
        self.client = Client(hub, **client_args)
        for s in subjects:
            self.client.subscribe(s)

    def fileno(self):
        return self.client.fileno()

    def close(self):
        self.client.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class CallClient(_OnClient):
    """A :class:`Caller` on its own :class:`Client`::

        with CallClient("127.0.0.1:7400", "echo") as c:
            print(c.call(['text value "hi"']).lines)

    :meth:`call` waits for the answer and raises :class:`CallError`; or keep
    your own loop with :meth:`start`, :meth:`poll` and :meth:`poll_outcome`.
    Extra keyword arguments go to :class:`Client` (``key=...``)."""

    def __init__(self, hub, service, ack_wait=ACK_WAIT, **client_args):
        self.caller = Caller(service, ack_wait=ack_wait)
        self._parked = deque()
        self._open(hub, self.caller.subjects(), client_args)

    def start(self, lines, timeout=5.0, priority=0):
        call_id = self.caller.call(time.monotonic(), lines, timeout, priority)
        self._flush()
        return call_id

    def _flush(self):
        while True:
            d = self.caller.poll_transmit()
            if d is None:
                return
            self.client.publish_raw(d)

    def poll(self, now=None):
        now = time.monotonic() if now is None else now
        self.client.poll(now)
        for _ in range(_MOST_PER_POLL):
            packet = self.client.recv()
            if packet is None:
                break
            self.caller.handle_packet(now, packet)
        self.caller.handle_timeout(now)
        self._flush()

    def next_deadline(self):
        return _earliest(self.client.next_deadline(), self.caller.poll_timeout())

    def poll_outcome(self):
        if self._parked:
            return self._parked.popleft()
        return self.caller.poll_outcome()

    def call(self, lines, timeout=5.0, priority=0):
        """Calls and waits; the :class:`Answer`, or raises :class:`CallError`."""
        call_id = self.start(lines, timeout, priority)
        while True:
            while True:
                got = self.caller.poll_outcome()
                if got is None:
                    break
                if got[0] == call_id:
                    if isinstance(got[1], CallError):
                        raise got[1]
                    return got[1]
                self._parked.append(got)
            now = time.monotonic()
            wake = _earliest(self.next_deadline(), now + 0.1)
            select.select([self.client], [], [], max(0.0, wake - now))
            self.poll()


class ServeClient(_OnClient):
    """A :class:`Provider` on its own :class:`Client`. ``handler(call)``
    returns the answer's lines, or raises to refuse the call (its message is
    the reason). It announces itself only once the hub has leased its
    subscriptions, so no caller hears of it before its calls can arrive.
    ``identity`` (an :class:`Identity`) is the key it seals with and its id;
    a new one by default."""

    def __init__(self, hub, service, lease=3.0, identity=None, **client_args):
        self.provider = Provider(service, time.monotonic(), lease, identity)
        self._open(hub, self.provider.subjects(), client_args)

    def _flush(self):
        if self.client.lease_ms is None:
            return
        while True:
            d = self.provider.poll_transmit()
            if d is None:
                return
            self.client.publish_raw(d)

    def next_deadline(self):
        return _earliest(self.client.next_deadline(), self.provider.poll_timeout())

    def poll(self, handler, now=None):
        """Serves the calls that arrived (a bounded batch), announcing
        between calls when due, so a slow handler does not make callers
        think this provider dead."""
        now = time.monotonic() if now is None else now
        self.client.poll(now)
        for _ in range(_MOST_PER_POLL):
            packet = self.client.recv()
            if packet is None:
                break
            call = self.provider.handle_packet(now, packet)
            # `accepted` (and any `who` answer) leaves before the handler runs.
            self._flush()
            if call is None:
                continue
            try:
                lines = handler(call)
                if isinstance(lines, str):
                    lines = lines.splitlines()
                self.provider.answer(call, lines)
            except Exception as e:  # the handler's failure is the caller's answer
                self.provider.refuse(call, "{}: {}".format(type(e).__name__, e))
            self.provider.handle_timeout(time.monotonic())
            self._flush()
        self.provider.handle_timeout(time.monotonic())
        self._flush()

    def serve(self, handler, until=None):
        """Serves until ``until()`` is true (or forever), then says it is leaving."""
        try:
            while until is None or not until():
                now = time.monotonic()
                wake = _earliest(self.next_deadline(), now + 0.1)
                select.select([self.client], [], [], max(0.0, wake - now))
                self.poll(handler)
        finally:
            self.leave()

    def leave(self):
        self.provider.leave()
        self._flush()


# --------------------------------------------------------------------------- command line


# --------------------------------------------------------------------------- MURDOCH

#: What every MURDOCH negotiation subject starts with.
NEGOTIATION_PREFIX = "murdoch."


def _pump(client, until):
    """Every packet that arrives before ``until`` (monotonic seconds), the
    client's refreshes kept up along the way."""
    got = []
    while True:
        now = time.monotonic()
        client.poll(now)
        got.extend(client)
        if now >= until:
            return got
        wait = until - now
        t = client.timeout(now)
        if t is not None:
            wait = min(wait, t)
        select.select([client], [], [], max(0.0, min(wait, 0.05)))


def announce_task(client, name, needs, length_s=5.0, deadline_s=60.0, announcer=None,
                  bid_window=0.2, ack_timeout=1.0, renew_interval=1.0, renew_timeout=3.0,
                  say=None, at=None, stats=None):
    """Introduces a task into a running MURDOCH system and follows it to its
    end, as ``colony tasks announce`` does: announces it to the idle robots
    that have ``needs``, awards it to the lowest bid, renews the award while
    the winner works, and auctions it again when the winner is lost (an
    abandon, a decline, or silence for ``renew_timeout``). A task nobody can
    take is announced again, with backoff, until ``deadline_s``.

    Every message it sends is sealed (:class:`Identity`, one key per call),
    and it acts only on sealed messages: the key that sealed a bidder token's
    first bid in an auction is that bidder, whose later bids, declines, acks,
    renewals, ``done`` and ``abandon`` count only from that key and each once,
    in order (a copy sent again is refused). A bid's score must lie within what
    the task's metrics can add up to (only 0 for a task with none).

    ``at``, an ``(x, y)`` in cm, says where the task is: robots bid by their
    distance to it (``--at`` of ``colony tasks announce``), and one driving a
    body goes there first; a robot with no position does not bid.

    Returns ``("done", winner)`` or ``("gave_up", reason)``. ``say``, if
    given, is called with a line for each step. ``stats``, if given a dict,
    counts what was heard: ``bids`` taken, ``forged`` (sealed, but not by the
    key that speaks for the bidder it names, a copy, or a score out of
    bounds) and ``rejected`` (unsealed, badly sealed or malformed)."""
    say = say or (lambda line: None)
    stats = {} if stats is None else stats
    for k in ("bids", "forged", "rejected"):
        stats.setdefault(k, 0)
    needs = sorted(set(needs.split(",") if isinstance(needs, str) else needs))
    for n in needs:
        if not is_subject(n):
            raise ValueError("{!r} is not a resource name".format(n))
    extra = []
    weights = []
    if at is not None:
        x, y = (float(v) for v in at)
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError("at {!r} is not a place".format(at))
        extra = [("param", [("name", "x"), ("value", x)]), ("param", [("name", "y"), ("value", y)]),
                 ("metric", [("name", "distance"), ("weight", 1.0)])]
        weights = [1.0]
    # Each metric is worth 0 to 1e6 (Rust's MAX_METRIC_VALUE) times its weight.
    bounds = (sum(min(w, 0.0) for w in weights) * _MAX_METRIC_VALUE,
              sum(max(w, 0.0) for w in weights) * _MAX_METRIC_VALUE)
    announcer = announcer or "py-{:04x}".format(random.getrandbits(16))
    identity = Identity()
    task = random.randint(1, 2**40)
    give_up_at = time.monotonic() + deadline_s
    backoff = 0.5
    reason = "not announced"
    attempt = 0

    def send(subjects, lines):
        client.publish_raw(identity.seal(build(subjects, 0, lines)))

    while True:
        attempt += 1
        neg = "{}{}.{}.{}".format(NEGOTIATION_PREFIX, announcer, task, attempt)
        client.subscribe(neg)
        # Subscribed before the announcement goes out: bids come at once.
        _pump(client, time.monotonic() + 0.2)
        task_line = ("task", [("name", name), ("id", task), ("negotiation", neg),
                              ("deadline_ms", int(bid_window * 1000)), ("length_s", float(length_s)),
                              ("announcer", announcer)])
        send(needs + ["idle"], [task_line] + extra)
        say("auction {} of {} open".format(attempt, name))
        bids = {}  # token -> [score, key, last n taken]
        for p in _pump(client, time.monotonic() + bid_window):
            m = _heard(p, neg, task, identity, stats)
            if m is None:
                continue
            label, who, score, key, n = m
            known = bids.get(who)
            if known is not None:
                if key != known[1] or n <= known[2]:
                    stats["forged"] += 1
                    continue
                known[2] = n
                if label == "bid" and bounds[0] <= score <= bounds[1]:
                    known[0] = score
                    stats["bids"] += 1
                elif label == "decline":
                    del bids[who]
            elif label == "bid" and bounds[0] <= score <= bounds[1] and len(bids) < _MOST_BIDS:
                bids[who] = [score, key, n]
                stats["bids"] += 1
            else:
                # A first word under a token that is no admissible bid binds no key.
                stats["forged"] += 1
        winner = None
        if bids:
            score, winner = min((v[0], t) for t, v in bids.items())
            send([neg], [("award", [("task", task), ("winner", winner), ("score", score),
                                    ("bids", len(bids))])])
            say("awarded to {} (score {:.2f}, {} bids)".format(winner, score, len(bids)))
            outcome = _follow(client, send, neg, task, announcer, identity, winner, bids[winner],
                              ack_timeout, renew_interval, renew_timeout, say, stats)
            if outcome == "done":
                client.unsubscribe(neg)
                return ("done", winner)
            reason = outcome
        else:
            reason = "no robot with {{{}}} is available".format(" ".join(needs))
            send([neg], [("unachievable", [("task", task), ("name", name), ("reason", reason)])])
            say("unachievable: " + reason)
        client.unsubscribe(neg)
        if time.monotonic() >= give_up_at:
            say("gave up: " + reason)
            return ("gave_up", reason)
        if winner is None:
            _pump(client, min(give_up_at, time.monotonic() + backoff))
            backoff = min(backoff * 2, 4.0)


#: What one metric can add to a score, per unit of weight (Rust's ``MAX_METRIC_VALUE``).
_MAX_METRIC_VALUE = 1e6
#: The largest number a MURDOCH message may carry (Rust's ``MAX_MAGNITUDE``).
_MAX_MAGNITUDE = 1e12
#: Bids one auction keeps: a flood of tokens cannot fill memory.
_MOST_BIDS = 4096
_TOKEN = re.compile(r"[A-Za-z0-9_-]{1,24}")
# Who each negotiation message names: the bidder it speaks for (None: no bidder's word).
_NAMES_BIDDER = {"bid": "bidder", "ack": "bidder", "decline": "bidder", "done": "bidder",
                 "abandon": "bidder", "renew": "by", "award": None, "cancel": None, "unachievable": None}


def _heard(packet, neg, task, identity, stats):
    """``(label, bidder, score, key, n)`` of a sealed message on ``neg`` about
    ``task`` that speaks for a bidder, or None; counts the unsealed and the
    malformed in ``stats["rejected"]``. Reads as the Rust ``Message::open``
    does: the seal first, then the first line of what it sealed."""
    if packet.subjects != [neg]:
        return None
    try:
        body, key, n = open_seal(packet.text.encode("utf-8"))
        inner = parse(body)
    except (SealError, ParseError):
        stats["rejected"] += 1
        return None
    if key == identity.key:
        return None  # its own, heard back
    label, fields = inner.lines[0] if inner.lines else (None, {})
    raw = _first_line_raw(inner)[1]
    t = fields.get("task")
    # A token is bare text; `12` parses as a number but is still a token.
    who = raw.get(_NAMES_BIDDER.get(label) or "")
    score = fields.get("score")
    if label == "bid":
        ok_score = (isinstance(score, (int, float)) and not isinstance(score, bool)
                    and math.isfinite(score) and abs(score) <= _MAX_MAGNITUDE)
    else:
        ok_score, score = True, None
    if (inner.subjects != [neg] or label not in _NAMES_BIDDER or isinstance(t, bool)
            or not isinstance(t, int) or t < 0 or not ok_score
            or (_NAMES_BIDDER[label] is not None and (who is None or not _TOKEN.fullmatch(who)))):
        stats["rejected"] += 1
        return None
    if t != task or who is None:
        return None
    return label, who, (float(score) if score is not None else None), key, n


def _follow(client, send, neg, task, announcer, identity, winner, bidder, ack_timeout,
            renew_interval, renew_timeout, say, stats):
    """The award's life: ``"done"``, or why the winner was lost. ``bidder`` is
    the winner's ``[score, key, last n]``: only that key speaks for it."""
    heard = None
    started = time.monotonic()
    next_renew = started
    while True:
        now = time.monotonic()
        if heard is None and now - started > ack_timeout:
            why = "{} never acknowledged".format(winner)
            send([neg], [("cancel", [("task", task), ("reason", why)])])
            return why
        if heard is not None and now - heard > renew_timeout:
            why = "presumed failed: no renewal for {:.1f} s".format(renew_timeout)
            send([neg], [("cancel", [("task", task), ("reason", why)])])
            say("{} lost ({}): auctioned again".format(winner, why))
            return why
        if now >= next_renew and heard is not None:
            send([neg], [("renew", [("task", task), ("by", announcer)])])
            next_renew = now + renew_interval
        for p in _pump(client, min(now + 0.05, next_renew if heard is not None else now + 0.05)):
            m = _heard(p, neg, task, identity, stats)
            if m is None:
                continue
            label, who, _, key, n = m
            if who != winner or key != bidder[1] or n <= bidder[2]:
                stats["forged"] += 1
                continue
            bidder[2] = n
            if label in ("ack", "renew"):
                if heard is None:
                    say("{} started".format(winner))
                heard = time.monotonic()
            elif label == "done":
                say("done by {}".format(winner))
                return "done"
            elif label == "abandon" or (label == "decline" and heard is None):
                why = "{} by {}".format(label, winner)
                say(why + ": auctioned again")
                send([neg], [("cancel", [("task", task), ("reason", why)])])
                return why


def _main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(prog="colony_client.py", description="A colony hub client.")
    ap.add_argument("--hub", default=None, help="HOST:PORT (default: $COLONY_HUB or 127.0.0.1:7400)")
    ap.add_argument(
        "--key", default=None, metavar="FILE", help="sign every packet with this key (the hub's --key FILE)"
    )
    sub = ap.add_subparsers(dest="command")
    p_sub = sub.add_parser("sub", help="subscribe and print packets as they arrive")
    p_sub.add_argument("subjects", nargs="+", metavar="SUBJECT")
    p_sub.add_argument("-n", "--count", type=int, default=None, help="stop after this many packets")
    p_pub = sub.add_parser("pub", help="publish one packet: SUBJECT... 'label name value ...'")
    p_pub.add_argument("-p", "--priority", type=int, default=0)
    p_pub.add_argument("words", nargs="+", metavar="SUBJECT... LINE...")
    sub.add_parser("status", help="print the hub's status")
    args = ap.parse_args(argv)

    try:
        client = Client(args.hub, key=None if args.key is None else read_key(args.key))
    except (OSError, ValueError) as e:
        print("colony_client: {}".format(e), file=sys.stderr)
        return 1
    try:
        if args.command == "sub":
            for s in args.subjects:
                client.subscribe(s)
            seen = 0
            while True:
                t = client.timeout()
                select.select([client], [], [], 0.25 if t is None else min(t, 0.25))
                client.poll()
                for packet in client:
                    sys.stdout.write(str(packet))
                    seen += 1
                    if args.count is not None and seen >= args.count:
                        sys.stdout.flush()
                        return 0
                sys.stdout.flush()
        elif args.command == "pub":
            words = args.words
            first = next((i for i, w in enumerate(words) if any(c.isspace() for c in w)), len(words))
            if first == 0:
                ap.error("give at least one subject before the lines")
            client.publish(words[:first], args.priority, words[first:])
            return 0
        elif args.command == "status":
            import json

            print(json.dumps(client.status(), indent=2))
            return 0
        else:
            ap.print_help()
            return 2
    except KeyboardInterrupt:
        return 130
    except (ParseError, ValueError, TimeoutError, OSError) as e:
        print("colony_client: {}".format(e), file=sys.stderr)
        return 1
    finally:
        client.close()


if __name__ == "__main__":
    sys.exit(_main())
