"""Search for the worlds where a stack fails: generate-and-test over the WorldSpec space, with a
candidate's fitness from its repeated runs (docs/search.md)."""
