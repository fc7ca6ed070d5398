"""Reports: deterministic JSON and its schema, each stage's report section, the readable text,
rules for CI gates, design diffs and JUnit."""
