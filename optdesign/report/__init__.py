"""What a person reads: JSON, tables, summaries and figures of kinematics, analyses, simulations,
optimisations and studies, every file written atomically (:mod:`.output`) and every results
folder replaced as a whole (:mod:`.folder`).  May import: errors, scene, kinematics, model,
dynamics and design; never study or cli (a study hands its rows in)."""
