"""The harmonic cores' parameter bounds, with the reasons ``hdl.emit --list`` prints.

Upper bounds from reality: the RAM words a part can have, the largest block a
part can hold, the memory this machine can spend elaborating.
"""

# One cluster RAM of MAX_DEPTH words x 18 bits is 18 Mbit: more block RAM than
# a whole Artix-7 200T (13 Mbit) or ECP5-85 (3.7 Mbit) has.
MAX_DEPTH = 1 << 20
DEPTH_WHY = ("a cluster RAM of 2**20 words x 18 bits is 18 Mbit, more block RAM than a whole "
             "Artix-7 200T (13 Mbit) or ECP5-85 (3.7 Mbit) has")
# Elaboration holds every RAM word as a Python object: about 0.8 KB a word
# (measured: a 65,536-word cluster takes 50 MB more than a 4,096-word one), so
# all the clusters of a top together hold at most 2**22 words (about 3.5 GB).
MAX_WORDS = 1 << 22
WORDS_WHY = ("elaborating holds every RAM word (about 0.8 KB each, measured): at most 2**22 words "
             "in all the clusters, about 3.5 GB, what this class of machine can spend")


# The largest block: elaborating takes about 10 MB and 5 s a cluster
# (measured: a 12x24 block of 16 clusters, 150 MB and 73 s more than one
# cluster), so at most 256 clusters, the paper's largest block (48x96,
# Table 3): about 2.5 GB and 20 minutes.
MAX_CLUSTERS = 256
CLUSTERS_WHY = ("elaborating takes about 10 MB and 5 s a cluster (measured): at most 256 clusters, "
                "the paper's largest block (48x96, Table 3), about 2.5 GB and 20 minutes")
# The blocks of a map: B * (p_max + 2) <= depth <= 2**20 with p_max >= 2.
MAX_BLOCKS_SIDE = 1 << 18
BLOCKS_WHY = "br * bc * (p_max + 2) <= depth <= 2**20 words: at most 2**18 blocks"
# A 16-bit exponent register per block (the default e_max, 255, is 8 bits).  A
# map needs e_max = 2 x its longest BFS distance to a goal (issue 22,
# models.harmonic.exponent_bound: the exact field falls by at most 4 a step):
# 65535 serves paths of 32767 steps; maze512-1-0 needs 10288 (14 bits).
MAX_E = (1 << 16) - 1
E_WHY = ("a 16-bit exponent register per block: a map needs 2 x its longest distance to a goal "
         "(models.harmonic.exponent_bound), so 65535 serves paths of 32767 steps")
