"""What ldbench makes of runs for people: the HTML report and summary, figures, the paper
reproductions with their published data, and the history plots.
"""
