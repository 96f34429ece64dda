"""Buildings: the automatic dominant-direction heading decision (``directions``) and the revisit pose graph
(``revisits``); docs/building.md."""
