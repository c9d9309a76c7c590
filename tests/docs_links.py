#!/usr/bin/env python3
"""Every Markdown link in the project points inside the project.

For each *.md file of the source tree (build folders, .git and caches
skipped), every link -- [text](target), ![alt](target), <a href="...">,
<img src="..."> and reference definitions [label]: target -- is checked:

- http(s) and mailto links are allowed (not fetched);
- any other scheme (file:, ftp:, ...) and absolute paths are refused: they
  point outside the repository;
- a relative target is resolved from the Markdown file's folder; it must stay
  inside the repository and name a file or folder that exists;
- an anchor (#part) on a Markdown target must match a heading of that file
  (GitHub's slugs) or an explicit id/name anchor.

Code blocks and inline code are not links. Usage:
    docs_links.py [REPO_ROOT]     (default: the parent of this file's folder)
Exit 0 when every link resolves, 1 with one line per bad link otherwise.
"""

import os
import re
import sys
from urllib.parse import unquote

SKIP_DIRS = {".git", ".cache", "node_modules", "__pycache__", "Testing"}
ALLOWED_SCHEMES = ("http://", "https://", "mailto:")

INLINE = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*(<[^>]*>|[^)\s]*)(?:\s+(?:\"[^\"]*\"|'[^']*'|\([^)]*\)))?\s*\)")
REFDEF = re.compile(r"^ {0,3}\[[^\]]+\]:\s*(<[^>]*>|\S+)")
HTML = re.compile(r"<(?:a|img)\b[^>]*?\b(?:href|src)\s*=\s*[\"']([^\"']*)[\"']", re.I)
HTML_ID = re.compile(r"<[a-z][^>]*?\b(?:id|name)\s*=\s*[\"']([^\"']+)[\"']", re.I)
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^ {0,3}(```+|~~~+)")


def skipped_dir(name):
    return name in SKIP_DIRS or name == "build" or name.startswith("build-")


def markdown_files(root):
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not skipped_dir(d))
        for f in sorted(files):
            if f.endswith(".md"):
                yield os.path.join(folder, f)


def text_lines(path):
    """(line number, text) outside fenced code, inline code blanked."""
    fence = None
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            m = FENCE.match(line)
            if fence:
                if m and m.group(1)[0] == fence[0] and len(m.group(1)) >= len(fence):
                    fence = None
                continue
            if m:
                fence = m.group(1)
                continue
            yield n, re.sub(r"(`+)(.+?)\1", lambda c: " " * len(c.group(0)), line.rstrip("\n"))


def slug(heading):
    """GitHub's anchor for a heading's text."""
    s = re.sub(r"`([^`]*)`", r"\1", heading)
    s = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", s)  # a link's text only
    s = re.sub(r"<[^>]+>", "", s)
    s = s.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


_anchors = {}


def anchors(path):
    if path not in _anchors:
        found, seen = set(), {}
        fence = None
        with open(path, encoding="utf-8") as f:
            for line in f:
                m = FENCE.match(line)
                if fence:
                    if m and m.group(1)[0] == fence[0] and len(m.group(1)) >= len(fence):
                        fence = None
                    continue
                if m:
                    fence = m.group(1)
                    continue
                for a in HTML_ID.findall(line):
                    found.add(a)
                h = HEADING.match(line)
                if h:
                    base = slug(h.group(2))
                    n = seen.get(base, 0)
                    seen[base] = n + 1
                    found.add(base if n == 0 else f"{base}-{n}")
        _anchors[path] = found
    return _anchors[path]


def check_target(root, md, target):
    """None when fine, else the reason."""
    if target.startswith("<") and target.endswith(">"):
        target = target[1:-1]
    if not target:
        return "empty link"
    low = target.lower()
    if low.startswith(ALLOWED_SCHEMES):
        return None
    if re.match(r"^[a-z][a-z0-9+.-]*:", low):
        return "points outside the repository (scheme " + low.split(":", 1)[0] + ")"
    if target.startswith("/") or target.startswith("\\") or re.match(r"^[A-Za-z]:[\\/]", target):
        return "absolute path: points outside the repository"
    path, _, anchor = target.partition("#")
    path = unquote(path.split("?", 1)[0])
    dest = os.path.normpath(os.path.join(os.path.dirname(md), path)) if path else md
    if os.path.commonpath([root, os.path.abspath(dest)]) != root:
        return "points outside the repository"
    if not os.path.exists(dest):
        return "no such file: " + os.path.relpath(dest, root)
    if anchor and dest.endswith(".md") and os.path.isfile(dest):
        if unquote(anchor) not in anchors(dest):
            return f"no heading for #{anchor} in {os.path.relpath(dest, root)}"
    return None


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                           os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    bad, files, links = [], 0, 0
    for md in markdown_files(root):
        files += 1
        for n, line in text_lines(md):
            targets = [m.group(1) for m in INLINE.finditer(line)]
            targets += HTML.findall(line)
            m = REFDEF.match(line)
            if m:
                targets.append(m.group(1))
            for t in targets:
                links += 1
                why = check_target(root, md, t)
                if why:
                    bad.append(f"{os.path.relpath(md, root)}:{n}: ({t}) {why}")
    for b in bad:
        print(b)
    print(f"docs_links: {files} Markdown files, {links} links, {len(bad)} bad")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
