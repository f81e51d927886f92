"""Reading the rows of the Markdown tables the report scripts write, for the tests that check their numbers."""


def rows_of(text, first_cells):
    """The cells of every Markdown table row of `text` starting with first_cells."""
    found = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[:len(first_cells)] == first_cells:
            found.append(cells)
    return found
