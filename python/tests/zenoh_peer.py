"""A Zenoh application colony did not write, on Zenoh's own Python package.

Run by the Rust test `bridge_cli.rs` with the endpoint of a `colony bridge`:
it asks for the colony channel `from_colony` the way any site does (a
liveliness token `colony/<site>/want/<channel>`), prints the first packet it
receives as `got KEY PAYLOAD`, then puts packets on `to_colony` as a site of
its own (`py`) until it is killed.
"""

import sys
import threading
import time

import zenoh


def main() -> None:
    endpoint = sys.argv[1]
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", f'["{endpoint}"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    got = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        if not got.is_set():
            text = sample.payload.to_bytes().decode("utf-8", "replace")
            print(f"got {sample.key_expr} {text!r}", flush=True)
            got.set()

    with zenoh.open(conf) as session:
        _want = session.liveliness().declare_token("colony/py/want/from_colony")
        _sub = session.declare_subscriber("colony/*/ch/from_colony", on_sample)
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            if got.is_set():
                session.put("colony/py/ch/to_colony", b"@ <to_colony> 0\nreply from python\n")
            time.sleep(0.1)


if __name__ == "__main__":
    main()
