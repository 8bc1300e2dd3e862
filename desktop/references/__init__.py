"""Batch numpy references on (N, 3) arrays of raw readings (nT in, nT out).

Each returns (matrix, offset, field) with h_c = matrix @ (h - offset):

- algebraic.fit_li_griffiths : ellipsoid-specific algebraic fit (Li & Griffiths 2004)
- mle.fit_geometric          : maximum likelihood, minimises sum (|M(h-b)| - R)^2
- paper_nn.fit_paper_nn      : the paper's linear neural network (section III.B)
- objective.fit_objective    : the streaming core's own objective, evaluated on
                               the samples (no moments): the strict cross-check
"""
