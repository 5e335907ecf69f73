#!/usr/bin/env python3
"""Every relative link in the project's Markdown (README.md, docs/, bench/, addon/) leads to a file that exists,
and every #anchor to a heading of the page it names (GitHub's slugs: lower case, punctuation dropped, spaces as
hyphens, -1, -2 for repeats). Prints each broken link and exits 1 when there is one.

    python3 tools/check_doc_links.py [checkout]
"""
import glob
import os
import re
import sys

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def pages(root):
    patterns = ("README.md", "docs/**/*.md", "bench/**/*.md", "addon/*.md")
    return sorted({p for pattern in patterns for p in glob.glob(os.path.join(root, pattern), recursive=True)})


def outside_code(path):
    """(line number, line) of a Markdown file, without the fenced code blocks."""
    fenced = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if line.lstrip().startswith("```"):
                fenced = not fenced
            elif not fenced:
                yield number, line


def slug(heading):
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(path):
    found, seen = set(), {}
    for _, line in outside_code(path):
        match = HEADING.match(line)
        if match:
            name = slug(match.group(2))
            repeat = seen.get(name, 0)
            seen[name] = repeat + 1
            found.add(name if repeat == 0 else "%s-%d" % (name, repeat))
    return found


def broken_links(root):
    checked, broken = 0, []
    for page in pages(root):
        for number, line in outside_code(page):
            for target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target):   # http:, mailto:
                    continue
                checked += 1
                path, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(page), path)) if path else page
                where = "%s:%d" % (os.path.relpath(page, root), number)
                if not os.path.exists(dest):
                    broken.append("%s: %s does not exist" % (where, target))
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    broken.append("%s: %s has no such heading" % (where, target))
    return checked, broken


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    checked, broken = broken_links(root)
    for line in broken:
        print(line)
    print("%d links checked, %d broken" % (checked, len(broken)))
    sys.exit(1 if broken else 0)


if __name__ == "__main__":
    main()
