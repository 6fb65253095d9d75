"""Reads an MCAP log with the `mcap` package from PyPI (a reader colony did not write) and
prints one JSON line per message, in file order, then one line with the file's summary.

Used by crates/colony/tests/mcap_logs.rs: `python3 mcap_dump.py FILE.mcap`. Each message line
holds its topic, schema (name, encoding, and whether its data is a JSON Schema object), message
encoding, sequence, log and publish times, and the message decoded as JSON (its exact packet
text, source and typed lines)."""

import json
import sys

from mcap.reader import make_reader


def main(path):
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        if summary is None:
            raise SystemExit(f"{path}: no summary")
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            schema_json = json.loads(schema.data) if schema is not None else None
            print(json.dumps({
                "topic": channel.topic,
                "schema": schema.name if schema is not None else None,
                "schema_encoding": schema.encoding if schema is not None else None,
                "schema_is_object": isinstance(schema_json, dict),
                "message_encoding": channel.message_encoding,
                "sequence": message.sequence,
                "log_time": message.log_time,
                "publish_time": message.publish_time,
                "message": json.loads(message.data),
            }))
        stats = summary.statistics
        print(json.dumps({"summary": {
            "message_count": stats.message_count,
            "channel_count": stats.channel_count,
            "chunk_count": stats.chunk_count,
            "chunk_indexes": len(summary.chunk_indexes),
        }}))


if __name__ == "__main__":
    main(sys.argv[1])
