#!/usr/bin/env python3
"""Prints each failed test case of the JUnit XML files under a directory
(ctest's, rostest's, gtest's, pytest's) with its first lines of failure:
scripts/test.sh prints them last, where a CI log's tail shows them."""
import pathlib
import sys
import xml.etree.ElementTree as ET

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".")
for path in sorted(root.rglob("*.xml")):
    try:
        cases = ET.parse(path).getroot().iter("testcase")
    except ET.ParseError as e:
        print(f"{path}: not XML ({e})")
        continue
    for case in cases:
        for bad in list(case.findall("failure")) + list(case.findall("error")):
            text = (bad.text or bad.get("message") or "").strip().splitlines()
            print(f"FAILED {path.name}: {case.get('classname', '')}.{case.get('name', '')}")
            for line in text[:12]:
                print(f"    {line[:300]}")
