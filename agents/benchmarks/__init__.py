"""How policies are judged: the fixed grid (``grid``), random points nobody tuned to (``blind``, its
targets ``targets``, a record over report seeds ``record``), a dense grid of the whole domain
(``dense``), the sensor policy on hidden parameters and load steps (``adaptation``), plots
(``plots``) and the model card (``model_card``)."""
