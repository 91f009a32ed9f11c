"""Analysis of trained and fixed controllers: rollouts (``rollout``), their metrics (``metrics``), reports and their
figures (``report``, ``plotting``) and learning curves (``curves``)."""
