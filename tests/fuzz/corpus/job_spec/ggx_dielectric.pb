
*ggx dielectric, alpha 0.3, Schlick f0 0.04ü©ñÒMbP? R0*(	333333Ó? *	{®Gáz¤?{®Gáz¤?{®Gáz¤?  ¨ 