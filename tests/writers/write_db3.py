#!/usr/bin/python3
"""usage: write_db3.py MESSAGES_JSON OUT_DB3 FLAVOUR

Writes a rosbag2 sqlite3 storage file (.db3) with Python's sqlite3 module, the
tables created as rosbag2_storage_sqlite3 creates them (SqliteStorage::initialize
in https://github.com/ros2/rosbag2/blob/rolling/rosbag2_storage_sqlite3/src/rosbag2_storage_sqlite3/sqlite_storage.cpp):
  FLAVOUR humble: schema version 3 (topics without type_description_hash, no
                  message_definitions table: the files of Humble);
  FLAVOUR jazzy:  schema version 4 (type_description_hash, message_definitions;
                  Iron and later), with two more topics: one whose definition is
                  ros2idl and one whose definition rosbag2 could not find
                  (encoding "unknown", empty).
MESSAGES_JSON is cdr_messages.js's output (CDR bytes by Foxglove's writer). The
messages are inserted in a shuffled order (row ids not in time order; two share
a timestamp), as a reader must sort them by timestamp, then id. A side file
OUT_DB3.json holds the topics as inserted (with their ids) and the messages in
the order rosbag2 plays them, data as hex.
"""
import json
import random
import sqlite3
import sys

QOS = ("- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 2147483647\n"
       "    nsec: 4294967295\n  lifespan:\n    sec: 2147483647\n    nsec: 4294967295\n  liveliness: 1\n"
       "  liveliness_lease_duration:\n    sec: 2147483647\n    nsec: 4294967295\n"
       "  avoid_ros_namespace_conventions: false")
IDL = "module example_msgs {\n  module msg {\n    struct Reading {\n      double value;\n    };\n  };\n};\n"


def create_tables(db, flavour):
    db.execute("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);")
    db.execute("CREATE TABLE metadata(id INTEGER PRIMARY KEY,metadata_version INTEGER NOT NULL,"
               "metadata TEXT NOT NULL);")
    if flavour == "humble":
        db.execute("CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
                   "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);")
    else:
        db.execute("CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,"
                   "serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL,"
                   " type_description_hash TEXT NOT NULL);")
        db.execute("CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,topic_type TEXT NOT NULL,"
                   "encoding TEXT NOT NULL,encoded_message_definition TEXT NOT NULL,"
                   "type_description_hash TEXT NOT NULL);")
    db.execute("CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,"
               "timestamp INTEGER NOT NULL, data BLOB NOT NULL);")
    db.execute("CREATE INDEX timestamp_idx ON messages (timestamp ASC);")
    db.execute("INSERT INTO schema (schema_version, ros_distro) VALUES (?, ?)",
               (3 if flavour == "humble" else 4, flavour))


def main():
    messages_json, out, flavour = sys.argv[1:4]
    if flavour not in ("humble", "jazzy"):
        sys.exit("FLAVOUR is humble or jazzy")
    written = json.load(open(messages_json))
    # (name, type, definition encoding, definition)
    topics = [(t["name"], t["type"], "ros2msg", t["definition"]) for t in written["topics"]]
    messages = [(m["topic"], int(m["log_time"]), bytes.fromhex(m["data"])) for m in written["messages"]]
    # one more on the topic of the 11th, at the 12th's timestamp (a tie broken by row id)
    messages.append((messages[10][0], messages[11][1], messages[12][2]))
    if flavour == "jazzy":
        topics += [("/reading", "example_msgs/msg/Reading", "ros2idl", IDL),
                   ("/thing", "custom_msgs/msg/Thing", "unknown", "")]
        reading = bytes([0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f])
        messages += [("/reading", messages[5][1] + 3, reading), ("/thing", messages[7][1] + 3, b"")]
    random.Random(7).shuffle(messages)

    db = sqlite3.connect(out)
    create_tables(db, flavour)
    ids = {}
    side = {"topics": [], "messages": []}
    for name, type_name, encoding, definition in topics:
        if flavour == "humble":
            cursor = db.execute("INSERT INTO topics (name, type, serialization_format, offered_qos_profiles) "
                                "VALUES (?, ?, ?, ?)", (name, type_name, "cdr", QOS))
            encoding, definition = "", ""
        else:
            cursor = db.execute("INSERT INTO topics (name, type, serialization_format, offered_qos_profiles, "
                                "type_description_hash) VALUES (?, ?, ?, ?, ?)",
                                (name, type_name, "cdr", QOS, "RIHS01_" + "ab" * 32))
            db.execute("INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, "
                       "type_description_hash) VALUES (?, ?, ?, ?)",
                       (type_name, encoding, definition, "RIHS01_" + "ab" * 32))
        ids[name] = cursor.lastrowid
        side["topics"].append({"id": cursor.lastrowid, "name": name, "type": type_name,
                               "serialization_format": "cdr", "definition_encoding": encoding,
                               "definition": definition})
    rows = []
    for name, stamp, data in messages:
        cursor = db.execute("INSERT INTO messages (timestamp, topic_id, data) VALUES (?, ?, ?)",
                            (stamp, ids[name], data))
        rows.append((stamp, cursor.lastrowid, ids[name], data))
    db.commit()
    db.close()
    for stamp, row, topic_id, data in sorted(rows):
        side["messages"].append({"id": row, "topic_id": topic_id, "timestamp": str(stamp), "data": data.hex()})
    with open(out + ".json", "w") as f:
        json.dump(side, f, indent=1)


if __name__ == "__main__":
    main()
